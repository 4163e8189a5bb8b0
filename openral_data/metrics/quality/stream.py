"""A data file's rows as episodes, read one row group at a time: each episode is assembled from consecutive rows
(an episode may span row groups, a row group may hold many episodes), so memory is bounded by one row group and
one episode, not by the file (lerobot rotates data files at 100 MB: a million frames may be one file).

That holds when the file's rows are in (episode_index, frame_index) order, as our writer and lerobot's write them;
a file out of order (an episode index seen before, a frame index going back: a foreign or converted file), or
whose indices are not integers or hold nulls, is read whole and sorted (`whole`), as it always was: its results
are the same either way."""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pyarrow as pa
import pyarrow.compute as pc

from openral_data.errors import DatasetError
from openral_data.formats.parquetfile import read_row_groups, read_table
from openral_data.metrics.quality.episode import Array

INDICES = ["episode_index", "frame_index"]
Ints = npt.NDArray[np.int64]


def vectors(table: pa.Table, key: str, path: Path) -> Array:
    """A list column as a float64 (rows, dims) array; NaN/Inf kept (the measures skip them)."""
    col = table.column(key).combine_chunks()
    n = len(col)
    if n and not pa.types.is_fixed_size_list(col.type) and not _even(col):
        raise DatasetError(f"{path}: {key}: rows of different lengths", code="dataset.invalid")
    flat = pc.list_flatten(col).to_numpy(zero_copy_only=False).astype(np.float64)
    if n and len(flat) % n:
        raise DatasetError(f"{path}: {key}: rows of different lengths", code="dataset.invalid")
    return np.asarray(flat.reshape(n, len(flat) // n if n else 0), dtype=np.float64)


def _even(col: pa.Array) -> bool:
    """Whether every row of list column `col` is present and of one length."""
    lengths = pc.list_value_length(col)
    bounds = pc.min_max(lengths)
    return not lengths.null_count and bounds["min"].as_py() == bounds["max"].as_py()


def in_order(path: Path) -> bool:
    """Whether `path`'s rows are in (episode_index, frame_index) order, integers without nulls: its episodes can
    be streamed (reads the two index columns, a row group at a time)."""
    last: tuple[int, int] | None = None
    for table in read_row_groups(path, INDICES):
        columns = [table.column(k) for k in INDICES]
        if any(not pa.types.is_integer(c.type) or c.null_count for c in columns):
            return False
        if not len(table):
            continue
        ep, fi = (c.to_numpy().astype(np.int64) for c in columns)
        if last is not None and (int(ep[0]), int(fi[0])) < last:
            return False
        step = np.diff(ep)
        if (step < 0).any() or (np.diff(fi)[step == 0] < 0).any():
            return False
        last = int(ep[-1]), int(fi[-1])
    return True


@dataclass(frozen=True)
class Episode:
    """One episode's rows of a data file, in order."""

    index: int
    frame_index: Ints
    stamps: Array
    arrays: dict[str, Array]  # state/action: (frames, dims)

    def rows(self, index: int, at: slice, copy: bool) -> Episode:
        """Rows `at` as episode `index` (views, or copies that do not hold these rows)."""

        def cut(x: npt.NDArray[Any]) -> npt.NDArray[Any]:
            return x[at].copy() if copy else x[at]

        return Episode(index, cut(self.frame_index), cut(self.stamps), {k: cut(x) for k, x in self.arrays.items()})


@dataclass
class Part:
    """The rows of one episode read so far (an episode may span row groups)."""

    index: int
    chunks: list[Episode] = field(default_factory=list)

    def whole(self) -> Episode:
        if len(self.chunks) == 1:
            return self.chunks[0]
        cs = self.chunks
        joined = {k: np.concatenate([c.arrays[k] for c in cs]) for k in cs[0].arrays}
        frames = np.concatenate([c.frame_index for c in cs])
        return Episode(self.index, frames, np.concatenate([c.stamps for c in cs]), joined)


def whole(path: Path, columns: list[str]) -> pa.Table:
    """`path`'s rows read whole and sorted by (episode_index, frame_index) (a stable sort)."""
    table = read_table(path, columns=columns)
    try:
        return table.sort_by([("episode_index", "ascending"), ("frame_index", "ascending")])
    except (KeyError, pa.ArrowException) as exc:
        raise DatasetError(f"{path}: episode_index/frame_index: {exc}", code="dataset.invalid") from None


def episodes(path: Path, keys: list[str]) -> Iterator[Episode]:
    """Data file `path`'s episodes in order, each with its frame indices, timestamps and `keys` vectors; streamed
    by row group when the file is in order (`in_order`), else from the whole file sorted."""
    columns = [*INDICES, "timestamp", *keys]
    tables: Iterable[pa.Table] = read_row_groups(path, columns) if in_order(path) else [whole(path, columns)]
    part: Part | None = None
    for table in tables:
        rows = Episode(
            -1,
            table.column("frame_index").to_numpy(zero_copy_only=False).astype(np.int64),
            table.column("timestamp").to_numpy(zero_copy_only=False).astype(np.float64),
            {k: vectors(table, k, path) for k in keys},
        )
        eps = table.column("episode_index").to_numpy(zero_copy_only=False).astype(np.int64)
        bounds = np.flatnonzero(np.diff(eps)) + 1
        for a, b in zip(np.concatenate([[0], bounds]), np.concatenate([bounds, [len(eps)]]), strict=True):
            if b <= a:
                continue
            if part is not None and part.index != int(eps[a]):
                yield part.whole()
                part = None
            part = part or Part(int(eps[a]))
            # the last run may go on in the next row group: a copy, so as not to hold this one meanwhile
            part.chunks.append(rows.rows(part.index, slice(a, b), copy=b == len(eps)))
    if part is not None:
        yield part.whole()
