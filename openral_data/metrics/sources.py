"""What `stats` and `view` are pointed at: LeRobot v3 datasets (ours or lerobot's) and results directories."""

from __future__ import annotations

import glob
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import pyarrow as pa

from openral_data.errors import DatasetError, NotFound
from openral_data.formats import lerobot_v2
from openral_data.formats import results as results_layout
from openral_data.formats.dataset import LeRobotDataset, open_lerobot
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.features import ACTION, STATE, dim_names
from openral_data.formats.lerobot_v3.images import ENVIRONMENT_STATE
from openral_data.formats.lerobot_v3.provenance import read_provenance
from openral_data.formats.lerobot_v3.reader import check_episode_count
from openral_data.formats.parquetfile import checked, read_schema, read_table


@dataclass(frozen=True)
class DatasetSource:
    """One dataset as DuckDB will read it: its files, its feature names and provenance."""

    label: str
    root: Path
    info: dict[str, Any]
    data_files: list[Path]
    episode_files: list[Path]
    episode_columns: frozenset[str]
    data_columns: frozenset[str]
    scene: str | None
    rskill: str | None
    robot: str | None
    # a LeRobot v2.x dataset's episodes and tasks, as v3's tables (its JSON lines are no parquet DuckDB can read)
    episodes_table: pa.Table | None = None
    tasks_table: pa.Table | None = None
    # the data columns (of the first data file, as `data_columns`) whose type is a plain bool: a flag per frame
    bool_data_columns: frozenset[str] = frozenset()

    @property
    def tasks_path(self) -> str:
        """The tasks file the dataset's layout has (v3: meta/tasks.parquet, v2.x: meta/tasks.jsonl)."""
        return layout.TASKS_PATH if self.tasks_table is None else lerobot_v2.TASKS_PATH

    def read_episodes(self, columns: list[str] | None = None) -> pa.Table:
        """The episodes table (all its files), `columns` only when given."""
        if self.episodes_table is not None:
            return self.episodes_table if columns is None else self.episodes_table.select(columns)
        return pa.concat_tables([read_table(f, columns=columns) for f in self.episode_files], promote_options="default")

    @property
    def fps(self) -> int:
        return int(self.info["fps"])

    @property
    def cameras(self) -> list[str]:
        return [k for k, f in self.info["features"].items() if f.get("dtype") == "video"]

    def dim_names(self, key: str) -> list[str]:
        """Per-dimension names from info.json (`features.dim_names`), else `<short key>_<i>` (state_0...)."""
        feature = self.info["features"].get(key)
        if feature is None:
            return []
        return dim_names(feature, "state" if key == STATE else key)

    @property
    def vector_features(self) -> list[str]:
        """The per-dimension vectors: state, action and lerobot's environment state, those the data has."""
        return [k for k in (STATE, ACTION, ENVIRONMENT_STATE) if k in self.data_columns]


def open_dataset(root: Path, label: str | None = None) -> DatasetSource:
    dataset = open_lerobot(root)
    if dataset.legacy:
        return _legacy_source(dataset, label)
    info = dataset.info
    for key in ("fps", "features"):
        if key not in info:
            raise DatasetError(f"{root / layout.INFO_PATH}: {key}: missing", code="dataset.invalid")
    episode_files = layout.found_files(root, "meta/episodes", "chunk-*/file-*.parquet")
    if not episode_files:
        raise DatasetError(f"{root}: no episodes metadata under meta/episodes/", code="dataset.invalid")
    data_files = layout.found_files(root, "data", "chunk-*/file-*.parquet")
    # the `datasets` view's episode count (read_table checks each episodes file is a regular file); lengths that
    # do not add up are the report's `frame_count` health finding
    check_episode_count(root, info, sum(read_table(f, columns=[]).num_rows for f in episode_files))
    for file in data_files:  # DuckDB opens them by name: none may be a FIFO or a device
        checked(file)
    episode_columns = _columns(episode_files[0])
    data_columns, bool_columns = _data_columns(data_files)
    scene = rskill = robot = None
    provenance = read_provenance(root)
    meta = provenance.origin if provenance is not None else None
    if meta is not None:
        scene, rskill, robot = meta.scene_id, meta.rskill_id, meta.robot
    return DatasetSource(
        label=label or root.name,
        root=root,
        info=info,
        data_files=data_files,
        episode_files=episode_files,
        episode_columns=episode_columns,
        data_columns=data_columns,
        scene=scene,
        rskill=rskill,
        robot=robot or info.get("robot_type"),
        bool_data_columns=bool_columns,
    )


def _legacy_source(dataset: LeRobotDataset, label: str | None) -> DatasetSource:
    """A LeRobot v2.x dataset for DuckDB: its episodes' data files (those present: `stats` reports the missing
    ones, `health`), its episodes and tasks as tables."""
    episodes = dataset.committed_episodes()
    data_files = [checked(f) for f in dataset.data_files() if f.exists()]  # DuckDB opens them: regular files only
    tasks = dataset.tasks()
    data_columns, bool_columns = _data_columns(data_files)
    return DatasetSource(
        label=label or dataset.root.name,
        root=dataset.root,
        info=dataset.info,
        data_files=data_files,
        episode_files=[],
        episode_columns=frozenset(episodes.column_names),
        data_columns=data_columns,
        bool_data_columns=bool_columns,
        scene=None,
        rskill=None,
        robot=dataset.info.get("robot_type"),
        episodes_table=episodes,
        tasks_table=pa.table(
            {"task_index": pa.array(range(len(tasks)), pa.int64()), "task": pa.array(tasks, pa.string())}
        ),
    )


def _columns(path: Path) -> frozenset[str]:
    return frozenset(read_schema(path).names)


def _data_columns(data_files: list[Path]) -> tuple[frozenset[str], frozenset[str]]:
    """The first data file's column names, and those of them whose type is bool (none without a data file)."""
    if not data_files:
        return frozenset(), frozenset()
    schema = read_schema(data_files[0])
    return frozenset(schema.names), frozenset(f.name for f in schema if f.type == pa.bool_())


def _is_input(path: Path) -> bool:
    return results_layout.is_results_dir(path) or (path / layout.INFO_PATH).is_file()


def _inputs(path: Path) -> list[Path]:
    """`path` itself when it is a dataset or results; a folder holding some (`datasets/`): those children, in
    name order (each its own group); else a DatasetError."""
    if _is_input(path):
        return [path]
    children = sorted(c for c in path.iterdir() if not c.name.startswith(".") and c.is_dir()) if path.is_dir() else []
    found = [c for c in children if _is_input(c)]
    if not found:
        raise DatasetError(
            f"{path}: neither a LeRobot v3 dataset (meta/info.json) nor results ({results_layout.SUMMARY}), nor a "
            "folder holding some",
            code="dataset.invalid",
        )
    return found


def resolve(paths: list[str]) -> tuple[list[DatasetSource], list[results_layout.Results]]:
    """Expand paths and globs into datasets and results directories; labels are made unique."""
    datasets: list[DatasetSource] = []
    results: list[results_layout.Results] = []
    for arg in paths:
        # a path that exists is itself, even with glob characters in its name (a folder `ds[1]` is not `ds1`)
        matches = sorted(glob.glob(arg)) if glob.has_magic(arg) and not Path(arg).exists() else [arg]
        if not matches:
            raise NotFound(f"{arg}: no such file or directory")
        for match in matches:
            path = Path(match)
            if not path.exists():
                raise NotFound(f"{path}: no such file or directory")
            for one in _inputs(path):
                if results_layout.is_results_dir(one):
                    results.append(results_layout.open_results(one))
                else:
                    datasets.append(open_dataset(one))
    seen: dict[str, int] = {}
    unique = []
    for ds in datasets:
        n = seen.get(ds.label, 0)
        seen[ds.label] = n + 1
        unique.append(ds if n == 0 else replace(ds, label=f"{ds.label}#{n + 1}"))
    return unique, results
