"""The per-frame index columns of each episode as lerobot's v3 loader needs them, rewritten where OLD's differ.

lerobot's writer numbers episodes 0..n-1, frames 0..length-1 (`frame_index`), the dataset's frames 0..total-1
(`index`), and stamps frame t at t / fps (`timestamp`); its v3 loader relies on all four (an episode is looked up
by its `episode_index`, a video frame at `from_timestamp + timestamp`). v2.x datasets on the Hub break them:
a subset kept from a larger dataset (its only episode is 29, its first index 10640: the converter pairs
episodes by position and refuses it), wall-clock timestamps (the converter converts them, then lerobot's loader
raises `FrameTimestampError`: the video's frames sit on the t / fps grid). `fixed_data` reads those four
columns of every episode; an episode whose columns already are what lerobot writes keeps OLD's file (a
timestamp within lerobot's default tolerance, 1e-4 s, of t / fps counts as right), any other is written again
into the scratch folder with the four columns set, everything else as stored. The statistics of the rewritten
columns are then computed again (`episode_stats`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pyarrow as pa
import pyarrow.parquet as pq

from openral_data.errors import DatasetError
from openral_data.formats.parquetfile import read_schema, read_table
from openral_data.upgrade.legacy import Legacy

TOLERANCE_S = 1e-4  # lerobot's LeRobotDataset(tolerance_s=1e-4)
INDEX_COLUMNS = ("episode_index", "frame_index", "index", "timestamp")


@dataclass
class FixedData:
    paths: list[Path] = field(default_factory=list)  # each episode's data file: OLD's, or its rewrite
    columns: dict[int, list[str]] = field(default_factory=dict)  # episode -> the columns rewritten

    @property
    def rewritten(self) -> list[str]:
        """Every column rewritten in some episode."""
        return sorted({c for columns in self.columns.values() for c in columns})


def fixed_data(legacy: Legacy, lengths: list[int], scratch: Path) -> FixedData:
    """Each episode's data file with lerobot's index columns (see the module docstring)."""
    fps = legacy.info["fps"]
    out = FixedData()
    start = 0
    for e, (path, n) in enumerate(zip(legacy.data, lengths, strict=True)):
        want = _wanted(e, start, n, fps)
        have = read_table(path, columns=[c for c in INDEX_COLUMNS if c in read_schema(path).names])
        wrong = [c for c in have.column_names if not _same(c, have.column(c), want[c], path)]
        out.paths.append(_rewritten(path, wrong, want, scratch / f"episode_{e:06d}.parquet") if wrong else path)
        if wrong:
            out.columns[e] = wrong
        start += n
    return out


def _rewritten(path: Path, columns: list[str], want: dict[str, npt.NDArray[Any]], dest: Path) -> Path:
    """`path`'s table with `columns` set to `want`'s values (their types kept), written to `dest`."""
    table = read_table(path)
    for name in columns:
        i = table.schema.get_field_index(name)
        field = table.schema.field(i)
        table = table.set_column(i, field, pa.array(want[name], field.type))
    dest.parent.mkdir(parents=True, exist_ok=True)
    pq.write_table(table, dest)
    return dest


def _wanted(e: int, start: int, n: int, fps: float) -> dict[str, npt.NDArray[Any]]:
    t = np.arange(n, dtype=np.int64)
    return {
        "episode_index": np.full(n, e, dtype=np.int64),
        "frame_index": t,
        "index": start + t,
        "timestamp": (t / fps).astype(np.float32),
    }


def _same(name: str, column: pa.ChunkedArray, want: npt.NDArray[Any], path: Path) -> bool:
    try:
        have = np.asarray(column.to_numpy(), dtype=np.float64 if name == "timestamp" else np.int64)
    except (pa.ArrowException, ValueError, TypeError) as exc:
        raise DatasetError(
            f"{path}: column {name!r}: not one number per frame ({exc})", code="dataset.invalid"
        ) from None
    if name == "timestamp":
        return bool(np.all(np.abs(have - want) <= TOLERANCE_S))
    return bool(np.array_equal(have, want))
