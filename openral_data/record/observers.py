"""The frame observers of a `record` run: what watches it without being part of it (`--view`, ...)."""

from __future__ import annotations

from pathlib import Path

from openral_data.record.options import RecordOptions
from openral_data.types import DatasetSchema, FrameObserver


def make_observers(opts: RecordOptions, out: Path, schema: DatasetSchema) -> list[FrameObserver]:
    """The observers `opts` asks for, in the order the bridge shows them each frame."""
    observers: list[FrameObserver] = []
    if opts.view:
        from openral_data.viz.live import open_live_view

        observers.append(open_live_view(schema, port=opts.view_port, address=opts.view_address))
    return observers


def check_observers(opts: RecordOptions) -> None:
    """What can be wrong with the observers' options (a busy `--view-port`, ...), found before anything is written."""
    if opts.view:
        from openral_data.viz.live import check_view_options

        check_view_options(opts.view_port, opts.view_address)
