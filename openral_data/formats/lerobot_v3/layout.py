"""Path templates and chunk/file numbering of LeRobotDataset v3."""

from __future__ import annotations

import operator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from openral_data.errors import DatasetError
from openral_data.paths import contained, contained_all, from_template, safe_name

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


def row_pos(row: dict[str, Any], prefix: str) -> FilePos:
    """The file an episodes row names under `prefix` (``data``, ``meta/episodes``, ``videos/<key>``)."""
    return FilePos(row[f"{prefix}/chunk_index"], row[f"{prefix}/file_index"])


@dataclass
class FileRun:
    """Consecutive files of one kind (data or meta/episodes parquet) that a writer joins into the first.

    The first file may already hold many episodes; every later one holds one committed episode. `sizes` and
    `rows` are each file's bytes and rows (frames for data, episodes for meta/episodes), in file order.
    """

    first: FilePos
    positions: list[FilePos] = field(default_factory=list)
    sizes: list[int] = field(default_factory=list)
    rows: list[int] = field(default_factory=list)

    @property
    def size(self) -> int:
        return sum(self.sizes)

    @property
    def total_rows(self) -> int:
        return sum(self.rows)

    def next_pos(self, chunks_size: int) -> FilePos:
        return self.positions[-1].next(chunks_size) if self.positions else self.first

    def add(self, pos: FilePos, size: int, rows: int) -> None:
        self.positions.append(pos)
        self.sizes.append(size)
        self.rows.append(rows)

    def copy(self) -> FileRun:
        return FileRun(self.first, list(self.positions), list(self.sizes), list(self.rows))


# Every file of a dataset we open or write is named by one of the functions below, and each refuses in one
# line (`paths.contained`, ``dataset.unsafe``) a path that symlinks (a folder or the file itself) lead outside
# the dataset: no reader copies an outside file in, no writer writes through a link out.


def inside(root: Path, rel: str) -> Path:
    """`root / rel` (a dataset-relative path of ours), refused unless it stays inside `root` after symlinks."""
    return contained(root, rel, str(root / rel))


def data_path(root: Path, pos: FilePos) -> Path:
    return inside(root, DATA_PATH.format(chunk_index=pos.chunk, file_index=pos.file))


def video_path(root: Path, key: str, pos: FilePos) -> Path:
    """The standard place of `key`'s video file `pos`; `key` (a feature name from info.json) must be one path
    component (`safe_name`)."""
    safe_name(key, f"{INFO_PATH}: features")
    return inside(root, VIDEO_PATH.format(video_key=key, chunk_index=pos.chunk, file_index=pos.file))


def template_path(root: Path, info: dict[str, Any], field: str, pos: FilePos, video_key: str | None = None) -> Path:
    """A file named by info.json's `field` template (``data_path``/``video_path``), refused in one line unless it
    formats and stays inside `root` (`contained`); a missing template means the standard one."""
    source = f"{root / INFO_PATH}: {field}"
    template = info.get(field) or TEMPLATES[field]
    values: dict[str, object] = {"chunk_index": pos.chunk, "file_index": pos.file}
    if video_key is not None:
        values["video_key"] = safe_name(video_key, f"{root / INFO_PATH}: features")
    return from_template(root, template, values, source)


def episodes_path(root: Path, pos: FilePos) -> Path:
    return inside(root, EPISODES_PATH.format(chunk_index=pos.chunk, file_index=pos.file))


def found_files(root: Path, folder: str, pattern: str) -> list[Path]:
    """The files matching the glob `pattern` below `root/folder` on disk, sorted; refused in one line if a
    symlink leads one of them (or its folder) outside `root` (`paths.contained_all`)."""
    found = sorted((root / folder).glob(pattern))
    return contained_all(root, [str(p.relative_to(root)) for p in found], str(root / folder / pattern))


def data_files(root: Path) -> list[Path]:
    """The frame tables (data/*/*.parquet) on disk, in chunk/file order."""
    return found_files(root, "data", "*/*.parquet")


def episodes_files(root: Path) -> list[Path]:
    """The episodes metadata tables (meta/episodes/*/*.parquet) on disk, in chunk/file order."""
    return found_files(root, "meta/episodes", "*/*.parquet")


def video_files(root: Path, key: str | None = None) -> list[Path]:
    """The video files (videos/KEY/chunk-*/file-*.mp4; every camera's without `key`) on disk, sorted."""
    if key is None:
        return found_files(root, "videos", "*/chunk-*/file-*.mp4")
    return found_files(root, f"videos/{safe_name(key, f'{INFO_PATH}: features')}", "chunk-*/file-*.mp4")
