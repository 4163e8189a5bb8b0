"""Path templates and chunk/file numbering of LeRobotDataset v3."""

from __future__ import annotations

import operator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from openral_data.errors import DatasetError
from openral_data.paths import contained, safe_name

CODEBASE_VERSION = "v3.0"
DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
VIDEO_PATH = "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4"
EPISODES_PATH = "meta/episodes/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
INFO_PATH = "meta/info.json"
STATS_PATH = "meta/stats.json"
TASKS_PATH = "meta/tasks.parquet"
OPENRAL_PATH = "meta/openral.json"
# openral-data's own bookkeeping, invisible to lerobot's loader (it only reads meta/, data/ and videos/)
STATE_DIR = ".openral"
LOCK_PATH = ".openral/lock"  # one writer at a time (fcntl lock)
JOURNAL_PATH = ".openral/journal.json"  # renames of an episode commit in progress
IMAGE_HIST_PATH = ".openral/image_hist.json"  # dataset-level camera histograms, so a resume keeps exact stats
RECORD_PATH = ".openral/record.json"  # the settings of `record`, so --resume continues with the same ones
QUARANTINE_DIR = ".openral/quarantine"  # what recovery or repair took out of the dataset, kept, never deleted
DEFAULT_CHUNKS_SIZE = 1000


MAX_INDEX = 10**6  # chunk and file indices are below this: they come from a dataset's rows (untrusted)
TEMPLATES = {"data_path": DATA_PATH, "video_path": VIDEO_PATH}  # what lerobot writes, exactly


@dataclass(frozen=True, order=True)
class FilePos:
    """(chunk_index, file_index); file indices run 0..chunks_size-1 inside a chunk.

    Both are integers in ``[0, MAX_INDEX)``, else a one-line `DatasetError` (``dataset.invalid``): they come
    from episodes rows and end up in file names.
    """

    chunk: int = 0
    file: int = 0

    def __post_init__(self) -> None:
        for name in ("chunk", "file"):
            value = getattr(self, name)
            try:
                index = operator.index(value)
            except TypeError:
                index = -1
            if isinstance(value, bool) or not 0 <= index < MAX_INDEX:
                raise DatasetError(
                    f"{name}_index {value!r} is not an integer in [0, {MAX_INDEX})", code="dataset.invalid"
                )
            object.__setattr__(self, name, index)

    def next(self, chunks_size: int = DEFAULT_CHUNKS_SIZE) -> FilePos:
        if self.file + 1 >= chunks_size:
            return FilePos(self.chunk + 1, 0)
        return FilePos(self.chunk, self.file + 1)


def data_path(root: Path, pos: FilePos) -> Path:
    return root / DATA_PATH.format(chunk_index=pos.chunk, file_index=pos.file)


def video_path(root: Path, key: str, pos: FilePos) -> Path:
    """The standard place of `key`'s video file `pos`; `key` (a feature name from info.json) must be one path
    component (`safe_name`)."""
    safe_name(key, f"{INFO_PATH}: features")
    return root / VIDEO_PATH.format(video_key=key, chunk_index=pos.chunk, file_index=pos.file)


def template_path(root: Path, info: dict[str, Any], field: str, pos: FilePos, video_key: str | None = None) -> Path:
    """A file named by info.json's `field` template (``data_path``/``video_path``), refused in one line unless it
    formats and stays inside `root` (`contained`); a missing template means the standard one."""
    source = f"{root / INFO_PATH}: {field}"
    template = info.get(field) or TEMPLATES[field]
    values: dict[str, object] = {"chunk_index": pos.chunk, "file_index": pos.file}
    if video_key is not None:
        values["video_key"] = safe_name(video_key, f"{root / INFO_PATH}: features")
    if not isinstance(template, str):
        raise DatasetError(f"{source}: {template!r} is not a path template", code="dataset.invalid")
    try:
        rel = template.format(**values)
    except (KeyError, IndexError, ValueError, AttributeError, TypeError) as exc:
        raise DatasetError(
            f"{source}: {template!r} is not a usable path template ({exc})", code="dataset.invalid"
        ) from None
    return contained(root, rel, source)


def episodes_path(root: Path, pos: FilePos) -> Path:
    return root / EPISODES_PATH.format(chunk_index=pos.chunk, file_index=pos.file)


def data_files(root: Path) -> list[Path]:
    """The frame tables (data/*/*.parquet) on disk, in chunk/file order."""
    return sorted((root / "data").glob("*/*.parquet"))


def episodes_files(root: Path) -> list[Path]:
    """The episodes metadata tables (meta/episodes/*/*.parquet) on disk, in chunk/file order."""
    return sorted((root / "meta" / "episodes").glob("*/*.parquet"))
