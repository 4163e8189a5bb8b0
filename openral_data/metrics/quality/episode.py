"""The state/action/timestamp measures of one episode, the `Finding`s that raise its flags, and its per-frame
speeds and idle flags."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from openral_data.formats.lerobot_v3.features import ACTION, STATE
from openral_data.metrics.quality import alignment, breadth, dims, leads, limits, motion, rows, timing
from openral_data.metrics.quality.findings import Finding, dim_subject, runs, span_findings
from openral_data.metrics.quality.thresholds import Thresholds
from openral_data.metrics.sources import DatasetSource

Array = npt.NDArray[np.float64]
Ranges = dict[str, tuple[Array, Array]]
FINDINGS = "finding_list"  # the key of a row's findings (not a column: `table.finish` writes them apart)
DIGEST, LENGTH = "content_digest", "length"  # keys `table.finish` compares across episodes, then drops
MOVING = "moving_frames"  # the frames where the arm moves (`arm_moving`): the camera pass reads it, then drops it
STEPS = "state_step_ratios"  # the state's step onto each frame over its neighbours' (`rows.step_ratios`): likewise


@dataclass(frozen=True)
class PerFrame:
    state_speed: Array | None  # range per second, per frame (None: the dataset has no such vector)
    action_speed: Array | None
    idle: npt.NDArray[np.bool_]


def idle_findings(idle: npt.NDArray[np.bool_], th: Thresholds) -> list[Finding]:
    """`idle` over every idle run when the idle share reaches `idle_flag`; else over an idle head or tail at
    least `idle_edge` of the episode long (value: its share of the frames)."""
    n = len(idle)
    share = float(idle.mean()) if n else 0.0
    if share >= th.idle_flag:
        return span_findings("idle", "episode", runs(idle, 2), share, th.idle_flag, detail="idle share of frames")
    head, tail = motion.run_lengths(idle)
    edges = [(0, head - 1, head, "idle head"), (n - tail, n - 1, tail, "idle tail")]
    return [
        Finding("idle", "episode", a, b, k / n, th.idle_edge, detail=what)
        for a, b, k, what in edges
        if k >= 2 and k >= th.idle_edge * n
    ]


def jerk_findings(z: Array, names: list[str], feature: str, fps: int, th: Thresholds) -> tuple[list[Finding], float]:
    """`jerky` windows of the trajectory `z` (range units; `names` its dimensions) and the worst share."""
    windows = motion.jerky_windows(z, fps, th.jerk_window_s, th.jerk_step, th.jerk_min_reversals)
    out = [
        Finding("jerky", dim_subject(feature, names[d]), a, b, share, th.jerk_reversal_share, detail="reversals")
        for d, a, b, share in windows
        if share >= th.jerk_reversal_share
    ]
    return out, max((w[3] for w in windows), default=0.0)


def vector_findings(
    ds: DatasetSource, key: str, x: Array, ranges: Ranges, arrays: dict[str, Array], th: Thresholds
) -> tuple[list[Finding], float | None, Array, list[str]]:
    """One vector's per-dimension findings, its clipped/saturated share, its trajectory without the gripper and
    constant dimensions (in range units) and their names."""
    lo, hi = ranges[key]
    names = ds.dim_names(key)
    grip = dims.gripper_dims(names)
    varies = motion.varies(lo, hi) & ~np.isin(np.arange(len(names)), grip)  # a gripper holds still on purpose
    found = dims.constant_tails(x, names, varies, th.frozen_min_frames, key)
    moving = [int(d) for d in np.flatnonzero(varies)]
    n = x.shape[0]
    if key == STATE:
        action_names = ds.dim_names(ACTION) if ACTION in arrays else []
        commands = {d: arrays[ACTION][:, action_names.index(nm)] for d, nm in enumerate(names) if nm in action_names}
        tops = dims.changing(dims.at_extremes(x, lo, hi, moving, th.clip_plateau, interior=True), dims.held(x))
        share = dims.share_of(tops, n)
        found += dims.frozen_state(x, (lo, hi), names, varies, commands, (th.clip_plateau, th.frozen_min_frames), key)
        for d, spans in tops.items():
            subject = dim_subject(key, names[d])
            found += span_findings("clipped", subject, spans, share, th.clip_flag, share >= th.clip_flag)
    else:
        tops = dims.at_extremes(x, lo, hi, moving, th.clip_plateau, interior=False)
        share = dims.share_of(tops, n)
        for d, spans in tops.items():
            found += span_findings("saturated", dim_subject(key, names[d]), spans, share, None, False)
    trajectory = motion.normalised(x[:, varies], lo[varies], hi[varies])
    angles = limits.robot_joints(ds.robot, names).revolute() if key == STATE else frozenset()
    if key == STATE:
        found += rows.degrees(x, names, key, th)
    found += breadth.non_finite(x, names, key) + breadth.quaternions(x, names, key, th)
    found += breadth.angle_wraps(x, names, key, angles) + breadth.duplicated(x, names, key)
    return found, (share if moving and n else None), trajectory, [names[d] for d in moving]


def gripper_findings(
    ds: DatasetSource, arrays: dict[str, Array], ranges: Ranges, n: int, th: Thresholds
) -> tuple[list[Finding], int | None]:
    """`chatter` of the action's gripper dimensions (else the state's): over each burst of toggles (each within
    half a flagging period of the one before), else from the first toggle to the last."""
    key = ACTION if dims.gripper_dims(ds.dim_names(ACTION)) and ACTION in arrays else STATE
    if key not in arrays or key not in ranges:
        return [], None
    names, (lo, hi) = ds.dim_names(key), ranges[key]
    out, most = [], None
    for g in dims.gripper_dims(names):
        frames = dims.toggle_frames(arrays[key][:, g], float(lo[g]), float(hi[g]))
        most = max(most or 0, len(frames))
        rate = len(frames) * ds.fps / n if n else 0.0
        if len(frames) >= th.chatter_min_toggles and rate >= th.chatter_hz:
            # where: its bursts (toggles at least twice the flagging rate), else first to last toggle
            spans = dims.bursts(frames, max(2, round(ds.fps / (2 * th.chatter_hz)))) or [(frames[0], frames[-1])]
            out += span_findings("chatter", dim_subject(key, names[g]), spans, rate, th.chatter_hz)
    return out, most


def timing_findings(steps: Array, th: Thresholds) -> list[Finding]:
    """A `gap` at each late (or not forward) frame, `jitter` at each frame off its period beyond the threshold."""
    late = (steps > th.gap_frames) | (steps <= 0)
    out = [
        Finding("gap", "timestamp", int(t) + 1, int(t) + 1, float(steps[t]), th.gap_frames)
        for t in np.flatnonzero(late)
    ]
    off = ~late & (np.abs(steps - 1.0) > th.jitter_flag)
    out += span_findings(
        "jitter",
        "timestamp",
        [(a + 1, b + 1) for a, b in runs(off)],
        timing.jitter(steps, th.gap_frames),
        th.jitter_flag,
    )
    return out


def arm_moving(
    arm: dict[str, tuple[Array, list[str]]], idle: npt.NDArray[np.bool_], fps: int, th: Thresholds
) -> npt.NDArray[np.bool_]:
    """The frames where the arm (the state without the gripper) moves faster than `idle_speed`; without a state,
    the frames that are not idle. A gripper closing while the arm holds still films a still scene."""
    if STATE not in arm or not arm[STATE][1]:
        return ~idle
    return np.asarray(motion.speeds(arm[STATE][0], fps) >= th.idle_speed, dtype=bool)


def row_findings(
    arrays: dict[str, Array],
    arm: dict[str, tuple[Array, list[str]]],
    steps: Array,
    th: Thresholds,
    targets: Array | None = None,
    pair: tuple[list[str], list[str]] | None = None,
) -> tuple[list[Finding], Array | None]:
    """`frame_drop`, `repeated_rows` and `teleport` (frame drops aside; `targets`: the state dimensions' position
    targets' steps, `alignment.target_steps`; `pair`: the action's and the state's dimension names, for the drops
    where a motion starts, `leads`) of the state trajectory `arm` holds, and its per-frame step ratios
    for the pictures' frame drops (`rows.step_ratios`; None without a state). The drops are measured on the
    position (`rows.positions`), and 2+ dimensions teleporting onto one frame are one (`rows.together`)."""
    if STATE not in arm:
        return [], None
    z, names = arm[STATE]
    late = (steps > th.gap_frames) | (steps <= 0)
    where = rows.positions(z, names, STATE)
    drops = rows.frame_drops(where, late, th, z)
    found = rows.frame_drop_findings(drops, th)
    if pair is not None and ACTION in arrays:
        near = {f + d for f, _ in drops for d in range(-rows.AROUND, rows.AROUND + 1)}
        early = leads.frame_drops(arrays[ACTION], arrays[STATE], pair, late, th.lead_factor)
        found += [f for f in early if f.start_frame not in near]
    cut = {f.start_frame or 0 for f in found}
    jumps, more = rows.together(z, names, rows.teleports(z, names, STATE, th, cut, targets), late, th)
    found += more + jumps
    ratios = rows.step_ratios(where, late, sorted(cut) + [f.start_frame or 0 for f in more])
    return found + rows.repeated_rows(list(arrays.values()), z, th), ratios


def targets(
    ds: DatasetSource, arrays: dict[str, Array], arm: dict[str, tuple[Array, list[str]]], ranges: Ranges
) -> Array | None:
    """The steps of the position targets of the arm's state dimensions, in their range units
    (`alignment.target_steps`); None without a state and an action."""
    if STATE not in arm or ACTION not in arrays:
        return None
    names = ds.dim_names(STATE)
    lo, hi = ranges[STATE]
    dims = [names.index(name) for name in arm[STATE][1]]
    return alignment.target_steps(arrays[ACTION], (ds.dim_names(ACTION), names), dims, hi - lo)


def episode_motion(
    ds: DatasetSource, arrays: dict[str, Array], timestamps: Array, ranges: Ranges, th: Thresholds
) -> tuple[dict[str, Any], PerFrame]:
    """One episode's measures (`arrays`: its state and action, frames in order), findings and per-frame values."""
    n, fps = len(timestamps), ds.fps
    z = {k: motion.normalised(x, *ranges[k]) for k, x in arrays.items() if k in ranges}
    speed = {k: motion.speeds(v, fps) for k, v in z.items()}
    idle = motion.idle_frames(speed.get(STATE), speed.get(ACTION), n, th.idle_speed)
    head, tail = motion.run_lengths(idle)
    found = idle_findings(idle, th)
    share: dict[str, float | None] = {}
    arm: dict[str, tuple[Array, list[str]]] = {}  # trajectories without the gripper (its steps are no jerk)
    for key, x in arrays.items():
        if key in ranges:
            more, share[key], traj, names = vector_findings(ds, key, x, ranges, arrays, th)
            found, arm[key] = found + more, (traj, names)
    jerk_key = ACTION if ACTION in arm else STATE
    worst = trajectory = None
    if jerk_key in arm:
        trajectory, names = arm[jerk_key]
        more, worst = jerk_findings(trajectory, names, jerk_key, fps, th)
        found += more
    grip, toggles = gripper_findings(ds, arrays, ranges, n, th)
    steps = timing.timestamp_steps(timestamps, fps)
    pair = (ds.dim_names(ACTION), ds.dim_names(STATE)) if STATE in arrays and ACTION in arrays else None
    in_rows, ratios = row_findings(arrays, arm, steps, th, targets(ds, arrays, arm, ranges), pair)
    found += grip + timing_findings(steps, th) + in_rows
    if STATE in arrays:
        found += limits.joint_findings(arrays[STATE], ds.robot, ds.dim_names(STATE), steps, fps, th)
    if pair is not None:
        found += alignment.alignment(arrays[ACTION], arrays[STATE], pair, th)
    row = {
        "idle_fraction": float(idle.mean()) if n else 0.0,
        "idle_head": head,
        "idle_tail": tail,
        "ldlj": motion.windowed_ldlj(trajectory, fps, th.jerk_window_s) if trajectory is not None else None,
        "jerk_reversal_share": worst,
        "gripper_toggles": toggles,
        "gripper_toggles_per_s": None if toggles is None or not n else toggles * fps / n,
        "action_saturated_fraction": share.get(ACTION),
        "state_clip_fraction": share.get(STATE),
        "timestamp_jitter": timing.jitter(steps, th.gap_frames),
        "timestamp_gaps": timing.gaps(steps, th.gap_frames),
        FINDINGS: found,
        DIGEST: breadth.digest(arrays),
        LENGTH: n,
        MOVING: arm_moving(arm, idle, fps, th),
        STEPS: ratios,
    }
    return row, PerFrame(speed.get(STATE), speed.get(ACTION), idle)
