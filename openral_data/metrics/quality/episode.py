"""The state/action/timestamp measures of one episode, and its per-frame speeds and idle flags."""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from openral_data.formats.lerobot_v3.features import ACTION, STATE
from openral_data.metrics.quality import dims, motion, timing
from openral_data.metrics.quality.thresholds import Thresholds
from openral_data.metrics.sources import DatasetSource

Array = npt.NDArray[np.float64]
Ranges = dict[str, tuple[Array, Array]]


@dataclass(frozen=True)
class PerFrame:
    state_speed: Array | None  # range per second, per frame (None: the dataset has no such vector)
    action_speed: Array | None
    idle: npt.NDArray[np.bool_]


def episode_motion(
    ds: DatasetSource, arrays: dict[str, Array], timestamps: Array, ranges: Ranges, th: Thresholds
) -> tuple[dict[str, Any], PerFrame]:
    """One episode's measures (`arrays`: its state and action, frames in order) and its per-frame values."""
    n, fps = len(timestamps), ds.fps
    z = {k: motion.normalised(x, *ranges[k]) for k, x in arrays.items() if k in ranges}
    speed = {k: motion.speeds(v, fps) for k, v in z.items()}
    idle = motion.idle_frames(speed.get(STATE), speed.get(ACTION), n, th.idle_speed)
    head, tail = motion.run_lengths(idle)
    frozen: list[dims.Frozen] = []
    clip: dict[str, float | None] = {}
    grippers: list[tuple[Array, float, float]] = []
    arm: dict[str, Array] = {}  # the trajectory without gripper dimensions (open/close steps are no jerk)
    for key, x in arrays.items():
        if key not in ranges:
            continue
        lo, hi = ranges[key]
        names = ds.dim_names(key)
        grip = dims.gripper_dims(names)
        varies = (hi > lo) & ~np.isin(np.arange(len(names)), grip)  # a gripper holds still on purpose
        frozen += dims.frozen_dims(key, x, names, varies, th.frozen_min_frames, th.frozen_min_share)
        clip[key] = dims.clip_fraction(x, lo, hi, set(grip), th.clip_plateau)
        arm[key] = motion.normalised(x[:, varies], lo[varies], hi[varies])
        if key == ACTION or not dims.gripper_dims(ds.dim_names(ACTION)):  # the action's gripper, else the state's
            grippers += [(x[:, g], float(lo[g]), float(hi[g])) for g in grip]
    toggles = max((dims.toggles(*g) for g in grippers), default=None)
    steps = timing.timestamp_steps(timestamps, fps)
    trajectory = arm.get(ACTION, arm.get(STATE))
    row = {
        "idle_fraction": float(idle.mean()) if n else 0.0,
        "idle_head": head,
        "idle_tail": tail,
        "frozen_dims": [asdict(f) for f in frozen],
        "ldlj": motion.windowed_ldlj(trajectory, fps, th.jerk_window_s) if trajectory is not None else None,
        "gripper_toggles": toggles,
        "gripper_toggles_per_s": None if toggles is None or not n else toggles * fps / n,
        "action_clip_fraction": clip.get(ACTION),
        "state_clip_fraction": clip.get(STATE),
        "timestamp_jitter": timing.jitter(steps, th.gap_frames),
        "timestamp_gaps": timing.gaps(steps, th.gap_frames),
    }
    return row, PerFrame(speed.get(STATE), speed.get(ACTION), idle)
