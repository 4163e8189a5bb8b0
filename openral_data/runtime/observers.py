"""The frame observers of a run: what watches it without being part of it (`--save-video`, `--view`), checked and
built from its options here, for `record` and for `replay --mode closed-loop` alike."""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

from openral_data.errors import OutputExists, UsageError
from openral_data.paths import check_creatable
from openral_data.types import DatasetSchema, FrameObserver

DEBUG_SUFFIX = ".debug"  # `--save-video` without a folder: `<out>.debug/`, beside the dataset (or results)


class ObserverOptions(Protocol):
    """The options observers are built from (`RecordOptions`, `ReplayOptions` have them)."""

    @property
    def save_video(self) -> bool: ...
    @property
    def save_video_dir(self) -> Path | None: ...
    @property
    def view(self) -> bool: ...
    @property
    def view_port(self) -> int: ...
    @property
    def view_address(self) -> str | None: ...


def make_observers(opts: ObserverOptions, out: Path, schema: DatasetSchema) -> list[FrameObserver]:
    """The observers `opts` asks for, for a run writing `out` (the dataset, or a replay's results), in the order
    the bridge shows them each frame (the bridge closes them). `check_observers` has refused what cannot work."""
    observers: list[FrameObserver] = []
    videos = video_folder(opts, out)
    if videos is not None:
        from openral_data.viz.debug_video import DebugVideo

        observers.append(DebugVideo(videos, schema))
    if opts.view:
        from openral_data.viz.live import open_live_view

        observers.append(open_live_view(schema, port=opts.view_port, address=opts.view_address))
    return observers


def check_observers(opts: ObserverOptions, out: Path, resume: bool = False, what: str = "the dataset") -> Path | None:
    """Refuse, before anything is written, observer options that cannot work (a busy `--view-port`, a debug video
    folder inside `out` or already holding videos, unless `resume` continues them); return the `--save-video`
    folder (None: no video)."""
    if opts.view:
        from openral_data.viz.live import check_view_options

        check_view_options(opts.view_port, opts.view_address)
    folder = video_folder(opts, out)
    if folder is None:
        return None
    source = "--save-video-dir" if opts.save_video_dir is not None else "--save-video"
    check_creatable(folder, source)
    if folder.resolve().is_relative_to(out.resolve()):
        raise UsageError(f"{folder}: {source}: inside {what} {out}; choose a folder outside it")
    if not resume:
        from openral_data.viz.debug_video import existing_videos

        if existing_videos(folder):
            raise OutputExists(
                f"{folder}: {source}: already holds debug videos; refusing to overwrite them (choose another folder)"
            )
    return folder


def video_folder(opts: ObserverOptions, out: Path) -> Path | None:
    """Where `--save-video` writes: `--save-video-dir`, else `<out>.debug/`; None without either option."""
    if not opts.save_video and opts.save_video_dir is None:
        return None
    return opts.save_video_dir if opts.save_video_dir is not None else out.with_name(out.name + DEBUG_SUFFIX)
