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

Some v2.1 datasets written by their authors' own scripts lack lerobot's default columns altogether (no `index`,
no `task_index`, neither in the parquet nor in info.json): lerobot 0.6.1 converts them and its loader then fails
(`CastError`, `KeyError: 'index'`). A missing `index`/`frame_index`/`episode_index`/`timestamp` is built as above;
a missing `task_index` is the episode's one task in `episodes.jsonl` (an episode listing several tasks cannot say
which frame did which: refused, naming the column), and info.json gains the features it lacked
(`missing_features`). A parquet column that is not a feature of info.json, or a feature (not a camera) missing
from the parquet, is refused by name: lerobot's loader reads exactly the declared columns.
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
DEFAULT_FEATURES: dict[str, dict[str, Any]] = {  # lerobot's DEFAULT_FEATURES, as its writer declares them
    "timestamp": {"dtype": "float32", "shape": [1], "names": None},
    "frame_index": {"dtype": "int64", "shape": [1], "names": None},
    "episode_index": {"dtype": "int64", "shape": [1], "names": None},
    "index": {"dtype": "int64", "shape": [1], "names": None},
    "task_index": {"dtype": "int64", "shape": [1], "names": None},
}
NOT_IN_PARQUET = ("video",)


@dataclass
class FixedData:
    paths: list[Path] = field(default_factory=list)  # each episode's data file: OLD's, or its rewrite
    columns: dict[int, list[str]] = field(default_factory=dict)  # episode -> the columns rewritten
    declared: list[str] = field(default_factory=list)  # default features info.json lacked, now declared
    moved_s: float = 0.0  # how far the farthest timestamp was moved onto the t / fps grid, in seconds

    @property
    def rewritten(self) -> list[str]:
        """Every column rewritten in some episode."""
        return sorted({c for columns in self.columns.values() for c in columns})


def fixed_data(legacy: Legacy, lengths: list[int], scratch: Path) -> FixedData:
    """Each episode's data file with lerobot's index columns (see the module docstring)."""
    fps = legacy.info["fps"]
    out = FixedData(declared=[k for k in DEFAULT_FEATURES if k not in legacy.features])
    for key in out.declared:  # declared as lerobot's writer does; their columns are built below
        legacy.features[key] = dict(DEFAULT_FEATURES[key])
    start = 0
    for e, (path, n) in enumerate(zip(legacy.data, lengths, strict=True)):
        names = read_schema(path).names
        _check_columns(legacy, path, names)
        want = _wanted(e, start, n, fps)
        have = read_table(path, columns=[c for c in INDEX_COLUMNS if c in names])
        wrong = [c for c in have.column_names if not _same(c, have.column(c), want[c], path)]
        if "timestamp" in wrong:
            out.moved_s = max(out.moved_s, _moved(have.column("timestamp"), want["timestamp"]))
        wrong += [c for c in INDEX_COLUMNS if c not in names]
        if "task_index" not in names:
            want["task_index"] = np.full(n, _task_of(legacy, e, path), dtype=np.int64)
            wrong.append("task_index")
        out.paths.append(_rewritten(path, wrong, want, scratch / f"episode_{e:06d}.parquet") if wrong else path)
        if wrong:
            out.columns[e] = wrong
        start += n
    return out


def _moved(column: pa.ChunkedArray, want: npt.NDArray[Any]) -> float:
    return float(np.max(np.abs(np.asarray(column.to_numpy(), dtype=np.float64) - want), initial=0.0))


def _check_columns(legacy: Legacy, path: Path, names: list[str]) -> None:
    """The parquet's columns are info.json's features (cameras stored in mp4 aside, default ones built here)."""
    extra = [c for c in names if c not in legacy.features]
    if extra:
        raise DatasetError(
            f"{path}: column {extra[0]!r} is not a feature of info.json; lerobot's loader reads exactly the declared "
            f"columns",
            code="dataset.invalid",
        )
    lacking = [
        k
        for k, ft in legacy.features.items()
        if k not in names and k not in DEFAULT_FEATURES and ft["dtype"] not in NOT_IN_PARQUET
    ]
    if lacking:
        raise DatasetError(
            f"{path}: column {lacking[0]!r} (a feature of info.json) is missing; nothing to rebuild it from",
            code="dataset.incomplete",
        )


def _task_of(legacy: Legacy, e: int, path: Path) -> int:
    """The task_index of episode `e`'s one task in episodes.jsonl (its frames carry no task_index column)."""
    tasks = legacy.episodes[e].get("tasks")
    index = {t.get("task"): int(t["task_index"]) for t in legacy.tasks}
    if not isinstance(tasks, list) or len(tasks) != 1 or tasks[0] not in index:
        raise DatasetError(
            f"{path}: column 'task_index' is missing, and episode {legacy.numbers[e]} lists {tasks!r:.80} in "
            f"meta/episodes.jsonl, not one task of meta/tasks.jsonl: which frame does which task is unknown",
            code="dataset.incomplete",
        )
    return index[tasks[0]]


def _rewritten(path: Path, columns: list[str], want: dict[str, npt.NDArray[Any]], dest: Path) -> Path:
    """`path`'s table with `columns` set to `want`'s values (their types kept; a missing column added with
    lerobot's type), written to `dest`."""
    table = read_table(path)
    added = [name for name in columns if name not in table.column_names]
    for name in columns:
        i = table.schema.get_field_index(name)
        if i < 0:
            table = table.append_column(name, pa.array(want[name], pa.from_numpy_dtype(want[name].dtype)))
            continue
        field = table.schema.field(i)
        table = table.set_column(i, field, pa.array(want[name], field.type))
    if added:  # the `datasets` schema metadata OLD's writer stored would name the columns it had, not these
        table = table.replace_schema_metadata(None)
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
