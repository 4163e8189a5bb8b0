"""An episode's rows of a data file, read without scanning the file: each file's footer is parsed once and kept,
with the episode_index range of every row group (from its statistics), so a request reads only the row groups
that may hold the episode (LeRobot v3 writers make one per episode: a 10,000-episode file has 10,000)."""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from pathlib import Path

import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from openral_data.errors import DatasetError
from openral_data.formats.parquetfile import checked


@dataclass
class _Index:
    metadata: pq.FileMetaData
    spans: list[tuple[int, int] | None]  # per row group: (min, max) episode_index, None without statistics


@dataclass
class EpisodeRows:
    """Cached footers of the data files read so far (a server's lifetime: the files are not expected to change)."""

    indexes: dict[Path, _Index] = field(default_factory=dict)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def read(self, path: Path, episode: int, columns: list[str]) -> pa.Table:
        """`columns` of episode `episode`'s rows of `path`, by frame_index; a bad file is a `DatasetError`."""
        keys = ["episode_index", "frame_index"]
        try:
            index = self._index(path)
            groups = [g for g, s in enumerate(index.spans) if s is None or s[0] <= episode <= s[1]]
            table = pq.ParquetFile(checked(path), metadata=index.metadata).read_row_groups(
                groups, columns=[*keys, *(c for c in columns if c not in keys)]
            )
            table = table.filter(pc.equal(table.column("episode_index"), episode)).sort_by("frame_index")
        except (pa.ArrowException, OSError, KeyError) as exc:
            raise DatasetError(f"{path}: {str(exc).splitlines()[0]}", code="dataset.invalid") from None
        return table.select(columns)

    def _index(self, path: Path) -> _Index:
        with self.lock:
            if path not in self.indexes:
                metadata = pq.read_metadata(checked(path))
                self.indexes[path] = _Index(metadata, _spans(metadata))
            return self.indexes[path]


def _spans(metadata: pq.FileMetaData) -> list[tuple[int, int] | None]:
    names = metadata.schema.names
    if "episode_index" not in names:
        return [None] * metadata.num_row_groups
    col = names.index("episode_index")
    out: list[tuple[int, int] | None] = []
    for g in range(metadata.num_row_groups):
        stats = metadata.row_group(g).column(col).statistics
        ok = stats is not None and stats.has_min_max
        out.append((int(stats.min), int(stats.max)) if ok else None)
    return out
