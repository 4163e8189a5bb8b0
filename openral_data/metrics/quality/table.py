"""The quality tables: one row per episode (its measures, one boolean flag per fault, and `flags` naming those
raised), one per frame (speeds, idle) and one per sampled camera frame (docs/stats.md, "Quality")."""

from __future__ import annotations

from typing import Any

import pyarrow as pa

from openral_data.metrics.quality.thresholds import Thresholds

CAMERA_MEASURES = ("black", "saturated", "frozen", "blurred")
FROZEN_DIM = pa.struct(
    [("feature", pa.string()), ("dim", pa.int64()), ("name", pa.string()), ("from_frame", pa.int64())]
)
MEASURES = pa.schema(
    [
        ("episode_index", pa.int64()),
        ("idle_fraction", pa.float64()),
        ("idle_head", pa.int64()),
        ("idle_tail", pa.int64()),
        ("frozen_dims", pa.list_(FROZEN_DIM)),
        ("ldlj", pa.float64()),
        ("gripper_toggles", pa.int64()),
        ("gripper_toggles_per_s", pa.float64()),
        ("action_clip_fraction", pa.float64()),
        ("state_clip_fraction", pa.float64()),
        ("timestamp_jitter", pa.float64()),
        ("timestamp_gaps", pa.int64()),
        *((f"camera_{m}_fraction", pa.float64()) for m in CAMERA_MEASURES),
        ("camera_first_black", pa.int64()),
        ("camera_flags", pa.list_(pa.string())),
        ("camera_stride", pa.int64()),
    ]
)
FRAME_SCHEMA = pa.schema(
    [
        ("episode_index", pa.int64()),
        ("frame_index", pa.int64()),
        ("state_speed", pa.float64()),
        ("action_speed", pa.float64()),
        ("idle", pa.bool_()),
    ]
)
SAMPLE_SCHEMA = pa.schema(
    [
        ("episode_index", pa.int64()),
        ("frame_index", pa.int64()),
        ("camera", pa.string()),
        ("luma", pa.float64()),
        ("change", pa.float64()),
        ("sharpness", pa.float64()),
        *((m, pa.bool_()) for m in CAMERA_MEASURES),
    ]
)
FLAGS = (
    *("idle", "frozen", "jerky", "chatter", "clipped", "jitter", "gap"),
    *(f"camera_{m}" for m in CAMERA_MEASURES),
)
SCHEMA = pa.schema(
    [*MEASURES, *((f, pa.bool_()) for f in FLAGS), ("flags", pa.list_(pa.string())), ("flagged", pa.bool_())]
)


def raised(row: dict[str, Any], th: Thresholds) -> dict[str, bool]:
    """Every flag of one episode's measures."""

    def over(value: float | None, limit: float) -> bool:
        return value is not None and value >= limit

    toggles, rate = row.get("gripper_toggles"), row.get("gripper_toggles_per_s")
    return {
        "idle": row["idle_fraction"] >= th.idle_flag,
        "frozen": bool(row["frozen_dims"]),
        "jerky": row["ldlj"] is not None and row["ldlj"] < th.jerk_ldlj,
        "chatter": over(toggles, th.chatter_min_toggles) and over(rate, th.chatter_hz),
        "clipped": over(row["action_clip_fraction"], th.clip_flag) or over(row["state_clip_fraction"], th.clip_flag),
        "jitter": row["timestamp_jitter"] > th.jitter_flag,
        "gap": row["timestamp_gaps"] > 0,
        **{f"camera_{m}": over(row.get(f"camera_{m}_fraction"), th.camera_flag) for m in CAMERA_MEASURES},
    }


def finish(rows: dict[int, dict[str, Any]], th: Thresholds, stride: int, *, has_cameras: bool) -> pa.Table:
    """The table of `rows` (episode -> measures), flags added, in episode order."""
    out = []
    for e in sorted(rows):
        row = {"episode_index": e, **rows[e], "camera_stride": stride if has_cameras else None}
        if not has_cameras:
            row.update({f"camera_{m}_fraction": None for m in CAMERA_MEASURES} | {"camera_flags": []})
        flags = raised(row, th)
        out.append({**row, **flags, "flags": [f for f, on in flags.items() if on], "flagged": any(flags.values())})
    return pa.Table.from_pylist(out, schema=SCHEMA)
