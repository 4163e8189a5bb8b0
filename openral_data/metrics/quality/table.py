"""The quality tables: one row per episode (its measures, one boolean flag per fault, and `flags` naming those
raised), one per frame (speeds, idle) and one per sampled camera frame (docs/stats.md, "Quality")."""

from __future__ import annotations

from typing import Any

import pyarrow as pa

from openral_data.metrics.quality import breadth
from openral_data.metrics.quality.camera import MEASURES as CAMERA_MEASURES
from openral_data.metrics.quality.episode import DIGEST, FINDINGS, LENGTH, MOVING, STEPS
from openral_data.metrics.quality.findings import FINDING_SCHEMA, Finding, finding_rows, flagged_checks, labels
from openral_data.metrics.quality.thresholds import Thresholds

MEASURES = pa.schema(
    [
        ("episode_index", pa.int64()),
        ("idle_fraction", pa.float64()),
        ("idle_head", pa.int64()),
        ("idle_tail", pa.int64()),
        ("ldlj", pa.float64()),
        ("jerk_reversal_share", pa.float64()),
        ("gripper_toggles", pa.int64()),
        ("gripper_toggles_per_s", pa.float64()),
        ("action_saturated_fraction", pa.float64()),
        ("state_clip_fraction", pa.float64()),
        ("timestamp_jitter", pa.float64()),
        ("timestamp_gaps", pa.int64()),
        *((f"camera_{m}_fraction", pa.float64()) for m in CAMERA_MEASURES),
        ("camera_first_black", pa.int64()),
        ("camera_flags", pa.list_(pa.string())),
        ("camera_stride", pa.int64()),
        ("data_kind", pa.string()),
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
        ("contrast", pa.float64()),
        *((m, pa.bool_()) for m in CAMERA_MEASURES),
    ]
)
FLAGS = (
    *("idle", "frozen", "jerky", "chatter", "clipped", "jitter", "gap"),
    *(f"camera_{m}" for m in CAMERA_MEASURES),
    *("camera_stalled", "video_frames", "camera_lag"),
    *("non_finite", "quat_flip", "quat_norm", "angle_wrap", "teleport", "duplicated"),
    *("frame_drop", "repeated_rows", "degrees", "action_swap", "action_lag", "camera_flipped"),
    *("task_text", "duplicate_episode", "length_outlier"),
    *("joint_limit", "joint_velocity"),
)
SCHEMA = pa.schema(
    [
        *MEASURES,
        *((f, pa.bool_()) for f in FLAGS),
        ("flags", pa.list_(pa.string())),
        ("flagged", pa.bool_()),
        ("findings", pa.list_(pa.string())),
    ]
)


def raised(findings: list[Finding]) -> dict[str, bool]:
    """Every flag of one episode: raised exactly when a flagging finding has its check."""
    on = flagged_checks(findings)
    return {f: f in on for f in FLAGS}


def finish(
    rows: dict[int, dict[str, Any]], stride: int, kind: str, th: Thresholds, *, has_cameras: bool
) -> tuple[pa.Table, pa.Table]:
    """The episodes' table of `rows` (episode -> measures and findings), flags added, in episode order, and the
    findings' table; `kind`: the kind of data whose thresholds were used (`thresholds.data_kind`)."""
    out, found = [], []
    across = breadth.duplicates({e: r.pop(DIGEST) for e, r in rows.items()})
    for e, more in breadth.length_outliers({e: r.pop(LENGTH) for e, r in rows.items()}, th).items():
        across[e] = across.get(e, []) + more
    for e in sorted(rows):
        rows[e].pop(MOVING, None)
        rows[e].pop(STEPS, None)
        row = {"episode_index": e, **rows[e], "camera_stride": stride if has_cameras else None, "data_kind": kind}
        findings: list[Finding] = row.pop(FINDINGS) + across.get(e, [])
        if not has_cameras:
            row.update({f"camera_{m}_fraction": None for m in CAMERA_MEASURES} | {"camera_flags": []})
        flags = raised(findings)
        flagged = [f for f, on in flags.items() if on]
        out.append({**row, **flags, "flags": flagged, "flagged": bool(flagged), "findings": labels(findings)})
        found += finding_rows(e, findings)
    return pa.Table.from_pylist(out, schema=SCHEMA), pa.Table.from_pylist(found, schema=FINDING_SCHEMA)
