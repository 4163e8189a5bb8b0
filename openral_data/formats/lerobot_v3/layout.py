"""Path templates and chunk/file numbering of LeRobotDataset v3."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

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


@dataclass(frozen=True, order=True)
class FilePos:
    """(chunk_index, file_index); file indices run 0..chunks_size-1 inside a chunk."""

    chunk: int = 0
    file: int = 0

    def next(self, chunks_size: int = DEFAULT_CHUNKS_SIZE) -> FilePos:
        if self.file + 1 >= chunks_size:
            return FilePos(self.chunk + 1, 0)
        return FilePos(self.chunk, self.file + 1)


def data_path(root: Path, pos: FilePos) -> Path:
    return root / DATA_PATH.format(chunk_index=pos.chunk, file_index=pos.file)


def video_path(root: Path, key: str, pos: FilePos) -> Path:
    return root / VIDEO_PATH.format(video_key=key, chunk_index=pos.chunk, file_index=pos.file)


def episodes_path(root: Path, pos: FilePos) -> Path:
    return root / EPISODES_PATH.format(chunk_index=pos.chunk, file_index=pos.file)


def data_files(root: Path) -> list[Path]:
    """The frame tables (data/*/*.parquet) on disk, in chunk/file order."""
    return sorted((root / "data").glob("*/*.parquet"))


def episodes_files(root: Path) -> list[Path]:
    """The episodes metadata tables (meta/episodes/*/*.parquet) on disk, in chunk/file order."""
    return sorted((root / "meta" / "episodes").glob("*/*.parquet"))
