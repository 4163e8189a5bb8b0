"""The frame observers of a `record` run (`--save-video`), built from its options by one function."""

from __future__ import annotations

from pathlib import Path

from openral_data.errors import OutputExists, UsageError
from openral_data.paths import check_creatable
from openral_data.record.options import RecordOptions
from openral_data.types import DatasetSchema, FrameObserver

DEBUG_SUFFIX = ".debug"  # `--save-video` without a folder: `<out>.debug/`, beside the dataset


def make_observers(opts: RecordOptions, out: Path, schema: DatasetSchema) -> list[FrameObserver]:
    """The observers `opts` asks for, for a recording into `out` (the bridge closes them)."""
    observers: list[FrameObserver] = []
    videos = check_observers(opts, out)
    if videos is not None:
        from openral_data.viz.debug_video import DebugVideo

        observers.append(DebugVideo(videos, schema))
    return observers


def check_observers(opts: RecordOptions, out: Path) -> Path | None:
    """Refuse, before anything is written, observer options that cannot work; return the `--save-video` folder
    (None: no debug video). It is `--save-video-dir`, else `<out>.debug/`; never inside the dataset (its readers
    must see it unchanged). A fresh recording refuses a folder that already holds debug videos."""
    if not opts.save_video and opts.save_video_dir is None:
        return None
    folder = opts.save_video_dir if opts.save_video_dir is not None else out.with_name(out.name + DEBUG_SUFFIX)
    source = "--save-video-dir" if opts.save_video_dir is not None else "--save-video"
    check_creatable(folder, source)
    if folder.resolve().is_relative_to(out.resolve()):
        raise UsageError(f"{folder}: {source}: inside the dataset {out}; choose a folder outside it")
    if not opts.resume:
        from openral_data.viz.debug_video import existing_videos

        if existing_videos(folder):
            raise OutputExists(
                f"{folder}: {source}: already holds debug videos; refusing to overwrite them (choose another folder)"
            )
    return folder
