"""The layout variants of LeRobot v3 that lerobot 0.6.1's loader reads, normalised in one place for every reader.

- `meta/tasks.parquet`: lerobot reads it with `pd.read_parquet` and names the index `task`, so the task text is
  whatever column the pandas metadata makes the index: `task` as lerobot >= 0.5 writes it (`tasks_table`), or
  the unnamed index (`__index_level_0__`) of datasets converted or recorded by older lerobot. `task_column` finds
  it, `tasks_table` gives the table as `task_index, task` whichever way it was stored.
- A camera feature's `names` spell the channel axis `channels` (lerobot's writer) or `channel` (its eval
  script); `camera_names` reads both as the same layout.
- A video feature's encoder settings sit in its `info` block, or in a legacy `video_info` block (next to `info`
  or instead of it); lerobot reads `is_depth_map` / `video.is_depth_map` from either. `feature_info` merges them.
- Statistics are optional (no `meta/stats.json`, a feature missing there, no `stats/...` episode columns):
  lerobot loads such a dataset, so readers treat a missing statistic as unknown, not as an error.
- A feature may carry its own `fps` (LeRobot v2.x wrote one on every feature, and lerobot's v2.1 -> v3.0
  converter keeps them); lerobot ignores it, so layouts compare without it (`without_fps`).
- `names` of a vector are a list, lerobot's one-entry `{"motors": [...]}` or null (`features.dim_names`).

Editing keeps the source's spelling of what it copies (info.json features verbatim); a file an edit writes anew
(tasks.parquet, stats) is written in the current lerobot form.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pyarrow as pa

from openral_data.errors import DatasetError

UNNAMED_INDEX = "__index_level_0__"  # how pandas stores an unnamed index in parquet
CHANNEL_NAMES = (["height", "width", "channels"], ["height", "width", "channel"])


def pandas_index(schema: pa.Schema) -> list[Any] | None:
    """The `index_columns` of the parquet's pandas metadata (None without readable metadata)."""
    raw = (schema.metadata or {}).get(b"pandas")
    if not raw:
        return None
    try:
        meta = json.loads(raw)
    except ValueError:
        return None
    index = meta.get("index_columns") if isinstance(meta, dict) else None
    return index if isinstance(index, list) else None


def task_column(schema: pa.Schema) -> str | None:
    """The column of tasks.parquet that holds the task text: the pandas index column when the metadata names one
    (`task`, or older lerobot's unnamed `__index_level_0__`), else a `task` column, else an unnamed index column
    stored without metadata; None when there is none."""
    index = pandas_index(schema)
    if (
        index
        and len(index) == 1
        and isinstance(index[0], str)
        and index[0] in schema.names
        and index[0] != "task_index"
    ):
        return index[0]
    for name in ("task", UNNAMED_INDEX):
        if name in schema.names:
            return name
    return None


def task_is_index(schema: pa.Schema) -> bool:
    """Whether lerobot reads the task text as the pandas index (so `item["task"]` is the text, not a number)."""
    column = task_column(schema)
    return column is not None and pandas_index(schema) == [column]


def tasks_table(table: pa.Table, path: Path) -> pa.Table:
    """tasks.parquet as columns `task_index, task`, whichever layout stored it; one error if it has no task text
    or no `task_index`."""
    column = task_column(table.schema)
    missing = [
        n for n, c in (("task_index", "task_index"), ("task", column)) if c is None or c not in table.schema.names
    ]
    if missing:
        raise DatasetError(
            f"{path}: no column {missing[0]!r} (nor the task text as the pandas index)", code="dataset.invalid"
        )
    return pa.table({"task_index": table.column("task_index"), "task": table.column(str(column))})


def feature_info(feature: dict[str, Any]) -> dict[str, Any]:
    """A feature's `info` block with a legacy `video_info` block merged under it (`info` wins on a clash)."""
    legacy = feature.get("video_info")
    info = feature.get("info")
    return {**(legacy if isinstance(legacy, dict) else {}), **(info if isinstance(info, dict) else {})}


def is_depth(feature: dict[str, Any]) -> bool:
    """lerobot's depth test: `is_depth_map` or the legacy `video.is_depth_map` in `info` or `video_info`."""
    info = feature_info(feature)
    return bool(info.get("is_depth_map") or info.get("video.is_depth_map"))


def camera_layout(feature: dict[str, Any]) -> dict[str, Any]:
    """A camera feature as its layout compares: height, width, channels order with `names` spelt
    `["height", "width", "channels"]` (lerobot also loads `channel`, a channel-first `["channel(s)", "height",
    "width"]` shape, and null names), and neither `info` nor `video_info` (encoder settings, not layout)."""
    out = {k: v for k, v in feature.items() if k not in ("info", "video_info")}
    names, shape = out.get("names"), out.get("shape")
    if names in CHANNEL_NAMES or names is None:
        out["names"] = CHANNEL_NAMES[0]
    elif names in [spelt[2:] + spelt[:2] for spelt in CHANNEL_NAMES] and isinstance(shape, list):
        out["names"], out["shape"] = CHANNEL_NAMES[0], [*shape[1:], *shape[:1]]
    return out


def without_fps(feature: dict[str, Any]) -> dict[str, Any]:
    """A feature without the per-feature `fps` key LeRobot v2.x wrote (lerobot reads the dataset's `fps`)."""
    return {k: v for k, v in feature.items() if k != "fps"}


def comparable(features: dict[str, Any]) -> dict[str, Any]:
    """info.json features with each variant spelt one way (`channels`; a `video_info` block merged into `info`),
    so that two datasets differing only in spelling compare equal (merge keeps the first one's spelling)."""
    out: dict[str, Any] = {}
    for key, feature in features.items():
        out[key] = without_fps(feature) if isinstance(feature, dict) else feature
        if isinstance(feature, dict) and feature.get("dtype") in ("video", "image"):
            info = feature_info(feature)
            out[key] = {**without_fps(camera_layout(feature)), **({"info": info} if info else {})}
    return out
