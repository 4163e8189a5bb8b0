"""Read back what a LeRobot v3 dataset holds (ours or lerobot's) without lerobot: info, tasks, episodes."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pyarrow as pa

from openral_data.errors import DatasetError
from openral_data.formats.jsonfile import read_json
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.info import check_info
from openral_data.formats.parquetfile import read_table


@dataclass(frozen=True)
class DatasetSummary:
    root: Path
    fps: int
    episodes: int
    frames: int
    tasks: list[str]
    cameras: list[str]
    successes: int | None  # None when the dataset records no per-episode success
    robot_type: str | None

    @property
    def success_rate(self) -> float | None:
        if self.successes is None or self.episodes == 0:
            return None
        return self.successes / self.episodes


def read_info(root: Path) -> dict[str, Any]:
    path = root / layout.INFO_PATH
    try:
        info: dict[str, Any] = read_json(path)
    except FileNotFoundError:
        raise DatasetError(
            f"{root}: not a LeRobot v3 dataset (no {layout.INFO_PATH})", code="dataset.invalid"
        ) from None
    return check_info(info, path)


def read_openral(root: Path) -> dict[str, Any] | None:
    """`meta/openral.json`, our provenance (writer, schema_metadata, config); None for a dataset without it
    (written by lerobot, or converted)."""
    try:
        data: dict[str, Any] = read_json(root / layout.OPENRAL_PATH)
    except FileNotFoundError:
        return None
    if not isinstance(data, dict):
        raise DatasetError(
            f"{root / layout.OPENRAL_PATH}: expected a JSON object, got {type(data).__name__}", code="dataset.invalid"
        )
    return data


def read_episodes(root: Path) -> pa.Table:
    files = layout.episodes_files(root)
    if not files:
        raise DatasetError(f"{root}: no episodes metadata under meta/episodes/", code="dataset.invalid")
    tables = [read_table(f) for f in files]
    try:
        return pa.concat_tables(tables, promote_options="default")
    except pa.ArrowException as exc:
        raise DatasetError(
            f"{root}: meta/episodes/: files do not fit together: {exc}", code="dataset.invalid"
        ) from None


def read_tasks(root: Path) -> list[str]:
    path = root / layout.TASKS_PATH
    table = read_table(path)
    try:
        rows = sorted(zip(table.column("task_index").to_pylist(), table.column("task").to_pylist(), strict=True))
    except KeyError as exc:
        raise DatasetError(f"{path}: no column {exc}", code="dataset.invalid") from None
    except TypeError:  # None or mixed values in task_index
        raise DatasetError(f"{path}: task_index: not all integers", code="dataset.invalid") from None
    return [str(task) for _, task in rows]


def summarize(root: Path) -> DatasetSummary:
    info = read_info(root)
    episodes = read_episodes(root)
    successes = None
    if "openral.success" in episodes.column_names:
        successes = sum(bool(v) for v in episodes.column("openral.success").to_pylist())
    return DatasetSummary(
        root=root,
        fps=info["fps"],
        episodes=info.get("total_episodes", 0),
        frames=info.get("total_frames", 0),
        tasks=read_tasks(root) if info.get("total_tasks") else [],
        cameras=[k for k, f in info["features"].items() if f.get("dtype") == "video"],
        successes=successes,
        robot_type=info.get("robot_type"),
    )
