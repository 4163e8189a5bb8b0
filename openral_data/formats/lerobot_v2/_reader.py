"""A v2.x dataset's metadata in the shapes the v3 readers take: info.json with v3 path templates, the tasks in
task_index order, and an episodes table with the v3 columns (where each episode's data and videos are)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pyarrow as pa

from openral_data.errors import DatasetError
from openral_data.formats.jsonfile import read_json
from openral_data.formats.lerobot_v2._jsonl import read_jsonl
from openral_data.formats.lerobot_v2._layout import (
    DATA_PATH,
    EPISODES_PATH,
    TASKS_PATH,
    VIDEO_PATH,
    as_v3_template,
    chunk_of,
)
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.info import check_info
from openral_data.formats.lerobot_v3.reader import check_paths, video_keys


def _is_int(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def read_raw_info(root: Path) -> dict[str, Any]:
    """meta/info.json as written, its types checked (`check_info`); no info.json is a one-line error."""
    path = layout.inside(root, layout.INFO_PATH)
    try:
        return check_info(read_json(path), path)
    except FileNotFoundError:
        raise DatasetError(
            f"{root}: not a LeRobot v3 dataset (no {layout.INFO_PATH})", code="dataset.invalid"
        ) from None


def as_v3_info(root: Path, raw: dict[str, Any]) -> dict[str, Any]:
    """v2.x info.json `raw` with v3 path templates (chunk_index = the episode's chunk, file_index = its index;
    lerobot's v2 templates where `raw` has none), checked to stay inside `root` (`check_paths`);
    ``codebase_version`` stays the source's."""
    info = dict(raw)
    info["data_path"] = as_v3_template(raw.get("data_path") or DATA_PATH)
    if video_keys(raw):
        info["video_path"] = as_v3_template(raw.get("video_path") or VIDEO_PATH)
    check_paths(root, info)
    return info


def read_tasks(root: Path, info: dict[str, Any]) -> list[str]:
    """meta/tasks.jsonl's texts in task_index order; the indices must be 0..n-1 and `total_tasks` count them."""
    path = layout.inside(root, TASKS_PATH)
    try:
        rows = read_jsonl(path)
    except FileNotFoundError:
        if info.get("total_tasks"):
            raise DatasetError(f"{path}: missing", code="dataset.incomplete") from None
        return []
    tasks: dict[int, str] = {}
    for row in rows:
        index: Any = row.get("task_index")
        task: Any = row.get("task")
        if not _is_int(index) or not isinstance(task, str):
            raise DatasetError(
                f"{path}: task_index/task: {row!r:.80} is not an integer and a text", code="dataset.invalid"
            )
        tasks[index] = task
    if sorted(tasks) != list(range(len(rows))):
        raise DatasetError(f"{path}: task_index: not 0..{len(rows) - 1}, each once", code="dataset.invalid")
    total = info.get("total_tasks")
    if total is not None and total != len(tasks):
        raise DatasetError(
            f"{root / layout.INFO_PATH}: total_tasks: {total}, but {TASKS_PATH} holds {len(tasks)} task(s)",
            code="dataset.invalid",
        )
    return [tasks[i] for i in range(len(tasks))]


def _episode_rows(root: Path, info: dict[str, Any]) -> list[tuple[int, int, list[str]]]:
    """(episode_index, length, tasks) of meta/episodes.jsonl, in episode order, the first `total_episodes`."""
    path = layout.inside(root, EPISODES_PATH)
    try:
        rows = read_jsonl(path)
    except FileNotFoundError:
        raise DatasetError(f"{path}: missing", code="dataset.incomplete") from None
    out: dict[int, tuple[int, int, list[str]]] = {}
    for n, row in enumerate(rows, start=1):
        e: Any = row.get("episode_index")
        length: Any = row.get("length")
        tasks: Any = row.get("tasks", [])
        if not (_is_int(e) and e >= 0 and _is_int(length) and length >= 0):
            raise DatasetError(f"{path}: line {n}: episode_index/length: not integers >= 0", code="dataset.invalid")
        if not isinstance(tasks, list) or not all(isinstance(t, str) for t in tasks):
            raise DatasetError(f"{path}: line {n}: tasks: not a list of texts", code="dataset.invalid")
        if e in out:
            raise DatasetError(f"{path}: line {n}: episode_index {e} listed twice", code="dataset.invalid")
        layout.FilePos(chunk_of(e, info), e)  # an index that can name a file
        out[e] = (e, length, tasks)
    total = info.get("total_episodes", len(out))
    if total > len(out):
        raise DatasetError(
            f"{root / layout.INFO_PATH}: total_episodes: {total}, but {EPISODES_PATH} holds {len(out)} episode(s)",
            code="dataset.invalid",
        )
    return [out[e] for e in sorted(out)][:total]


def read_episodes(root: Path, info: dict[str, Any]) -> pa.Table:
    """The episodes as v3's meta/episodes table: episode_index, tasks, length, dataset_from_index/to_index (the
    frames' global `index` range), data/chunk_index and data/file_index (the episode's chunk and index: its file
    by the v3 templates of `as_v3_info`) and per video camera its file likewise, from 0 to length / fps seconds
    (each v2 episode video starts at 0). `total_frames` must be the lengths' sum."""
    rows = _episode_rows(root, info)
    lengths = [n for _, n, _ in rows]
    if info.get("total_frames", sum(lengths)) != sum(lengths):
        raise DatasetError(
            f"{root / layout.INFO_PATH}: total_frames: {info['total_frames']}, but the episodes' lengths add up to "
            f"{sum(lengths)}",
            code="dataset.invalid",
        )
    ids = [e for e, _, _ in rows]
    chunks = [chunk_of(e, info) for e in ids]
    starts = _cumulative(lengths)
    columns: dict[str, pa.Array] = {
        "episode_index": pa.array(ids, pa.int64()),
        "tasks": pa.array([t for _, _, t in rows], pa.list_(pa.string())),
        "length": pa.array(lengths, pa.int64()),
        "dataset_from_index": pa.array(starts, pa.int64()),
        "dataset_to_index": pa.array([s + n for s, n in zip(starts, lengths, strict=True)], pa.int64()),
        "data/chunk_index": pa.array(chunks, pa.int64()),
        "data/file_index": pa.array(ids, pa.int64()),
    }
    fps = int(info["fps"])
    for key in video_keys(info):
        columns[f"videos/{key}/chunk_index"] = pa.array(chunks, pa.int64())
        columns[f"videos/{key}/file_index"] = pa.array(ids, pa.int64())
        columns[f"videos/{key}/from_timestamp"] = pa.array([0.0] * len(ids), pa.float64())
        columns[f"videos/{key}/to_timestamp"] = pa.array([n / fps for n in lengths], pa.float64())
    return pa.table(columns)


def _cumulative(lengths: list[int]) -> list[int]:
    starts, total = [], 0
    for n in lengths:
        starts.append(total)
        total += n
    return starts


def data_files(root: Path, info: dict[str, Any], episodes: pa.Table) -> list[Path]:
    """The data parquet of every episode of `episodes` (`read_episodes`), in episode order, inside `root`."""
    return [
        layout.template_path(root, info, "data_path", layout.FilePos(c, f))
        for c, f in zip(
            episodes.column("data/chunk_index").to_pylist(), episodes.column("data/file_index").to_pylist(), strict=True
        )
    ]
