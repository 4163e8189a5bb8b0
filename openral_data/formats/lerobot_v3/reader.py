"""Read back what a LeRobot v3 dataset holds (ours or lerobot's) without lerobot: info, tasks, episodes."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pyarrow as pa

from openral_data.errors import DatasetError
from openral_data.formats.jsonfile import read_json
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.info import check_info
from openral_data.formats.lerobot_v3.missing import MissingFiles, missing_files
from openral_data.formats.lerobot_v3.success import count_successes, episode_successes
from openral_data.formats.lerobot_v3.variants import tasks_table
from openral_data.formats.parquetfile import read_table
from openral_data.paths import safe_name


@dataclass(frozen=True)
class DatasetSummary:
    root: Path
    fps: int
    episodes: int
    frames: int
    tasks: list[str]
    cameras: list[str]
    successes: int | None  # None when no episode's success is known (see `success.episode_successes`)
    robot_type: str | None
    success_known: int = 0  # episodes whose success is known (the rate's denominator)
    missing: MissingFiles | None = None  # files a partial download left out (`missing.missing_files`)
    codebase_version: str | None = None  # info.json's

    @property
    def success_rate(self) -> float | None:
        if self.successes is None or self.success_known == 0:
            return None
        return self.successes / self.success_known

    def to_json(self) -> dict[str, object]:
        """The fields of `info --json`, in docs/scripting.md's order."""
        return {
            "path": str(self.root),
            "episodes": self.episodes,
            "frames": self.frames,
            "fps": self.fps,
            "duration_s": self.frames / self.fps,
            "cameras": list(self.cameras),
            "tasks": list(self.tasks),
            "robot_type": self.robot_type,
            "success_known": self.successes is not None and self.success_known > 0,
            "successes": self.successes,
            "success_rate": self.success_rate,
            "missing": self.missing.to_json() if self.missing else None,
            "codebase_version": self.codebase_version,
        }


def counted_episodes(root: Path) -> int:
    """info.json's episode count as it is on disk now (a writer renames it last: counted means fully renamed); -1 when
    it is unreadable or missing (nothing beyond what the caller knows is counted)."""
    try:
        return int(read_info(root).get("total_episodes", 0))
    except Exception:  # noqa: BLE001 - unreadable or missing: nothing counted
        return -1


def read_info(root: Path) -> dict[str, Any]:
    """`meta/info.json`, checked for what would make a path out of it leave the dataset (`check_paths`)."""
    path = layout.inside(root, layout.INFO_PATH)
    try:
        info: dict[str, Any] = read_json(path)
    except FileNotFoundError:
        raise DatasetError(
            f"{root}: not a LeRobot v3 dataset (no {layout.INFO_PATH})", code="dataset.invalid"
        ) from None
    check_paths(root, refuse_legacy(root, check_info(info, path)))
    return info


LEGACY_VERSIONS = ("v2.0", "v2.1")  # read in place by `formats.dataset` (read-only commands); upgraded for the rest


def refuse_legacy(root: Path, info: dict[str, Any]) -> dict[str, Any]:
    """`info` unless it is a LeRobot v2.x one: the v3 readers (every writing command) refuse those in one line
    naming `openral-data upgrade`."""
    version = info.get("codebase_version")
    if version in LEGACY_VERSIONS:
        raise DatasetError(
            f"{root / layout.INFO_PATH}: codebase_version: {version}: LeRobot v2.x is not read here (the CLI's "
            f"dataset commands but push and generate take it); run `openral-data upgrade {root} NEW` for a v3 "
            "dataset first",
            code="dataset.unsupported",
        )
    return info


def check_paths(root: Path, info: Any) -> None:
    """Refuse, in one line, an info.json whose features or path templates would lead outside `root`.

    info.json is untrusted: a video feature key becomes a folder (``videos/{key}/``) and the ``data_path`` /
    ``video_path`` templates become file paths, so each key must be one path component (`safe_name`) and
    each template must format to a path inside the dataset (`layout.template_path`).
    """
    source = f"{root / layout.INFO_PATH}"
    if not isinstance(info, dict):
        raise DatasetError(f"{source}: not a JSON object", code="dataset.invalid")
    features = info.get("features", {})
    if not isinstance(features, dict) or not all(isinstance(f, dict) for f in features.values()):
        raise DatasetError(f"{source}: features: must map names to objects", code="dataset.invalid")
    for key in video_keys(info):
        safe_name(key, f"{source}: features")
    for field in layout.TEMPLATES:
        if info.get(field) is not None:
            layout.template_path(root, info, field, layout.FilePos(), video_key="key")


def video_keys(info: dict[str, Any]) -> list[str]:
    """The features info.json stores as videos (each one a folder under ``videos/``)."""
    return [k for k, f in info.get("features", {}).items() if isinstance(f, dict) and f.get("dtype") == "video"]


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


def dataset_tasks(root: Path, info: dict[str, Any]) -> list[str]:
    """The task texts in task_index order, which info.json's `total_tasks` must count (`info` and `tasks list`
    print them: a `total_tasks` of 0 must not hide the tasks there are)."""
    total = info.get("total_tasks")
    tasks = read_tasks(root) if total or os.path.lexists(root / layout.TASKS_PATH) else []
    if total is not None and total != len(tasks):
        raise DatasetError(
            f"{root / layout.INFO_PATH}: total_tasks: {total}, but {layout.TASKS_PATH} holds {len(tasks)} task(s)",
            code="dataset.invalid",
        )
    return tasks


def read_tasks_table(root: Path) -> pa.Table:
    """meta/tasks.parquet as columns `task_index, task`, in any layout lerobot reads (`variants.tasks_table`)."""
    path = layout.inside(root, layout.TASKS_PATH)
    return tasks_table(read_table(path), path)


def read_tasks(root: Path) -> list[str]:
    path = layout.inside(root, layout.TASKS_PATH)
    table = read_tasks_table(root)
    try:
        rows = sorted(zip(table.column("task_index").to_pylist(), table.column("task").to_pylist(), strict=True))
    except TypeError:  # None or mixed values in task_index
        raise DatasetError(f"{path}: task_index: not all integers", code="dataset.invalid") from None
    return [str(task) for _, task in rows]


def summarize(root: Path) -> DatasetSummary:
    info = read_info(root)
    episodes = committed_episodes(root, info, read_episodes(root))
    successes, known = count_successes(episode_successes(root, episodes))
    return DatasetSummary(
        root=root,
        fps=info["fps"],
        episodes=info.get("total_episodes", 0),
        frames=info.get("total_frames", 0),
        tasks=dataset_tasks(root, info),
        cameras=[k for k, f in info["features"].items() if f.get("dtype") in ("video", "image")],
        successes=successes if known else None,
        robot_type=info.get("robot_type"),
        success_known=known,
        missing=missing_files(root, info, episodes),
        codebase_version=info.get("codebase_version"),
    )


def committed_episodes(root: Path, info: dict[str, Any], episodes: pa.Table) -> pa.Table:
    """The rows of the episodes table that info.json's totals count: its first `total_episodes` (rows past them
    are an unfinished commit's, which `doctor --repair` finishes). `info` prints the totals, so claiming episodes
    that are not there, or frames their lengths do not add up to, is one line (`doctor`: `info.totals`), never a
    wrong count. Episode lengths must be integers >= 0."""
    where = f"{root / layout.INFO_PATH}"
    n = check_episode_count(root, info, episodes.num_rows)
    episodes = episodes.slice(0, n)
    if "length" not in episodes.column_names:
        return episodes
    lengths = episodes.column("length").to_pylist()
    if not all(isinstance(v, int) and v >= 0 for v in lengths):
        raise DatasetError(f"{root}/meta/episodes/: length: not all integers >= 0", code="dataset.invalid")
    if info.get("total_frames", sum(lengths)) != sum(lengths):
        raise DatasetError(
            f"{where}: total_frames: {info['total_frames']}, but the episodes' lengths add up to {sum(lengths)}",
            code="dataset.invalid",
        )
    return episodes


def check_episode_count(root: Path, info: dict[str, Any], rows: int) -> int:
    """info.json's `total_episodes` (default: `rows`), which must not claim more than the `rows` of the episodes
    table (rows past it are an unfinished commit's)."""
    n = info.get("total_episodes", rows)
    if n > rows:
        raise DatasetError(
            f"{root / layout.INFO_PATH}: total_episodes: {n}, but meta/episodes/ holds {rows} episode(s)",
            code="dataset.invalid",
        )
    return int(n)
