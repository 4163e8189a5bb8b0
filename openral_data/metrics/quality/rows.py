"""Checks on whole rows of one episode and on a dimension's units, each a list of `Finding`s with frames: a
hidden frame drop (`frame_drop`), rows written again (`repeated_rows`), a state dimension far off its local speed
(`teleport`) and an angle written in degrees (`degrees`) (docs/stats.md, "Quality")."""

from __future__ import annotations

import math
import warnings
from collections import Counter

import numpy as np
import numpy.typing as npt

from openral_data.formats.lerobot_v3.features import STATE
from openral_data.metrics import signals
from openral_data.metrics.quality.findings import Finding, dim_subject, runs
from openral_data.metrics.quality.thresholds import Thresholds

Array = npt.NDArray[np.float64]
REPEATS = 2  # `repeated_rows`: an episode with more places repeating rows repeats them by nature
NEAR = 5  # frames either side whose steps make a step's local speed
JUMPS = 3  # `teleport`: a dimension jumping more often than this in one episode jumps by nature (a hand's fingers
# snapping open and shut), a teleport is a one-off
AROUND = 2  # `frame_drop`: the steps either side a drop's step is compared with
ALIGN = 0.8  # `frame_drop`: the step's direction against its neighbours' (cosine): the same motion, further on
# `frame_drop`: ... every moving dimension further by about the same factor (largest / median ratio; calibration
# corpus: dropped frames 1.0-3.8, a teleport in a moving episode 8.3 and more)
SPREAD = 5.0
MOVED = 0.002  # range units: a dimension moving less than this on its neighbouring steps is not compared
# `teleport` on quantised readings (a real robot's encoders): a step of at most `COUNTS_FLOOR` counts of the
# dimension's resolution (its smallest nonzero step in the episode) is no teleport (a dimension whose range is one
# count flickers by 100 % of it); nor is a step under `ALONE` times the larger of its two neighbouring steps (a
# gripper closing in 3 frames): a teleport is one step alone (calibration corpus, tuning half: injected teleports
# 4.0x their neighbours and more, people's clean jumps 2.2x at most)
COUNTS_FLOOR = 3.0
ALONE = 3.0
# `frame_drop`: this many dimensions jumping onto one frame (`teleports`) are frames lost, not a teleport (the
# fault moves one dimension; frames lost carry every moving dimension on at once)
TOGETHER = 2


def local_speed(step: Array) -> Array:
    """(steps, dims) absolute steps -> the mean of the `NEAR` steps either side of each, itself left out (fewer
    at the episode's ends); a running sum, so linear in the episode's length."""
    n = len(step)
    total = np.concatenate([np.zeros((1, step.shape[1])), np.cumsum(np.nan_to_num(step), axis=0)])
    t = np.arange(n)
    lo, hi = np.maximum(t - NEAR, 0), np.minimum(t + NEAR + 1, n)
    count = (hi - lo - 1).clip(min=1)[:, None]
    return np.asarray((total[hi] - total[lo] - np.nan_to_num(step)) / count, dtype=np.float64)


def teleports(
    z: Array, names: list[str], feature: str, th: Thresholds, skip: set[int], targets: Array | None = None
) -> list[Finding]:
    """`teleport`: a state dimension (`z` in dataset-range units, quaternion components left to `quat_flip`)
    stepping between two frames more than `teleport_step` of its range and more than `teleport_factor` times its
    local speed (the mean step within `NEAR` frames; still there, its median step when it moves), and further than
    its position target moved in one frame within `NEAR` frames (`targets`: `alignment.target_steps`, in the same
    units; a follower catching up with its command is no teleport); the frame it lands on (the 5 jumps most
    beyond their local speed; frames in `skip`, a frame drop, left out; a dimension jumping more than `JUMPS`
    times in the episode left out: its nature)."""
    if len(z) < 3:
        return []
    quat = {names[i] for _, dims in signals.quaternion_groups(feature, names) for i in dims}
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a dimension that never moves: no median step (NaN)
        step = np.abs(np.diff(z, axis=0))
        usual = np.nan_to_num(np.nanmedian(np.where(step > 0, step, np.nan), axis=0))
        typical = np.nan_to_num(local_speed(step))
        typical = np.where(typical > 0, typical, usual)  # still nearby: its usual step when it moves
        jump = (step > th.teleport_step) & (step > th.teleport_factor * typical) & lone_jumps(step)
        if targets is not None and len(targets):
            jump &= step > commanded(targets)
    out = []
    with np.errstate(divide="ignore", invalid="ignore"):
        beyond = step / typical  # how far beyond its local speed: the 5 kept are the 5 most beyond it
    hits = [(float(beyond[t, d]), int(t), int(d)) for t, d in zip(*np.nonzero(jump), strict=True)]
    often = np.bincount([d for _, t, d in hits if t + 1 not in skip], minlength=z.shape[1]) > JUMPS
    for _, t, d in sorted(hits, reverse=True):
        if names[d] in quat or t + 1 in skip or often[d]:
            continue
        value = float(step[t, d] / typical[t, d]) if typical[t, d] > 0 else math.inf
        subject = dim_subject(feature, names[d])
        out.append(Finding("teleport", subject, t + 1, t + 1, value, th.teleport_factor, detail="x local speed"))
    return sorted(out[:5], key=lambda f: f.start_frame or 0)


def together(
    z: Array, names: list[str], jumps: list[Finding], late: npt.NDArray[np.bool_], th: Thresholds
) -> tuple[list[Finding], list[Finding]]:
    """`jumps` (`teleports`' findings on `z`, dimensions `names`) split: those that stay teleports, and a
    `frame_drop` (about the state, its value the smallest of the jumps, in local speeds) on each frame where at
    least `TOGETHER` dimensions jump, each the way it steps on the steps just before and after (a motion carried
    on), while the timestamps say one period passed (`late`: a `gap`). Frames lost carry the moving dimensions
    on at once: where the cut is long or the arm turns within it, further than `frame_drops` asks of one motion
    going on (its direction, its even spread), yet each dimension steps far beyond its own local speed."""
    step = np.diff(z, axis=0)
    index = {dim_subject(STATE, name): d for d, name in enumerate(names)}

    def carried(f: Finding) -> bool:
        t, d = (f.start_frame or 0) - 1, index.get(f.subject)
        if d is None or t < 1 or t + 1 >= len(step) or late[t]:
            return False
        return bool(np.sign(step[t - 1, d]) == np.sign(step[t, d]) == np.sign(step[t + 1, d]) != 0)

    count = Counter(f.start_frame for f in jumps if carried(f))
    cut = sorted(f for f, c in count.items() if f is not None and c >= TOGETHER)
    detail = f"{TOGETHER}+ dimensions jumping on beyond their local speed at once, timestamps even"
    drops = [
        Finding(
            "frame_drop",
            STATE,
            f,
            f,
            min(j.value or 0.0 for j in jumps if j.start_frame == f),
            th.teleport_factor,
            detail=detail,
        )
        for f in cut
    ]
    return [j for j in jumps if j.start_frame not in cut], drops


def commanded(targets: Array) -> Array:
    """(steps, dims) |steps| of each dimension's position target -> the largest within `NEAR` steps either side."""
    padded = np.pad(targets, ((NEAR, NEAR), (0, 0)))
    return np.asarray(np.lib.stride_tricks.sliding_window_view(padded, 2 * NEAR + 1, axis=0).max(axis=-1))


def lone_jumps(step: Array) -> npt.NDArray[np.bool_]:
    """(steps, dims) absolute steps -> whether each is more than `COUNTS_FLOOR` counts of its dimension's
    resolution and `ALONE` times both neighbouring steps (an episode's first or last step: its one neighbour)."""
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a dimension that never moves: no resolution (NaN)
        count = np.nan_to_num(np.nanmin(np.where(step > 0, step, np.nan), axis=0))
        pad = np.zeros((1, step.shape[1]))
        near = np.fmax(np.concatenate([pad, step[:-1]]), np.concatenate([step[1:], pad]))
        return np.asarray((step > COUNTS_FLOOR * count) & (step >= ALONE * np.nan_to_num(near)), dtype=bool)


def positions(z: Array, names: list[str], feature: str) -> Array:
    """`z` (range units) without its quaternion components (`signals.quaternion_groups`), for the frame drops:
    an end effector's orientation spans a few thousandths of each component's [-1, 1], so in range units its
    noise and its wobble where a motion starts step as far as the position's motion and swamp the step's norm
    (left to `quat_flip`, as `teleports` leaves them)."""
    quat = {i for _, dims in signals.quaternion_groups(feature, names) for i in dims}
    return z[:, [i for i in range(z.shape[1]) if i not in quat]] if quat else z


def frame_drops(
    z: Array, late: npt.NDArray[np.bool_], th: Thresholds, every: Array | None = None
) -> list[tuple[int, float]]:
    """(frame, step over its neighbours') where the state (`z`, range units; `positions`) steps `drop_factor`
    times further than on each of the `AROUND` steps either side, all of them moving (not a start from rest), in
    the direction its two neighbouring steps move (frames lost, the motion goes on where it would have been), its
    dimensions `every` (the whole state, quaternions included; else `z`) stepping evenly further (`spread`),
    while the timestamps say one period passed (`late`: the steps that are a gap, already found as `gap`); at
    most 5. Two steps either side, not one: a script speeding up between waypoints steps further from one frame
    on, so its step after is as long (no spike); a drop is one long step between ordinary ones. The orientation
    stays in the spread: with it, one position jumping alone while the hand turns on is a teleport."""
    if len(z) < 2 * AROUND + 2 or z.shape[1] == 0:
        return []
    with np.errstate(all="ignore"):
        step = np.nan_to_num(np.diff(z, axis=0), posinf=0.0, neginf=0.0)
        norm = np.linalg.norm(step, axis=1)
        n = len(norm)
        near = np.stack([norm[AROUND + d : n - AROUND + d] for d in range(-AROUND, AROUND + 1) if d])
        both = step[AROUND - 1 : n - AROUND - 1] + step[AROUND + 1 : n - AROUND + 1]
        mine = step[AROUND : n - AROUND]
        cosine = (mine * both).sum(axis=1) / (norm[AROUND : n - AROUND] * np.linalg.norm(both, axis=1))
        ratio = norm[AROUND : n - AROUND] / near.max(axis=0)
        hit = (ratio > th.drop_factor) & (near.min(axis=0) > 0) & (cosine > ALIGN)
    whole = step if every is None else np.nan_to_num(np.diff(every, axis=0), posinf=0.0, neginf=0.0)
    hit &= ~late[AROUND : n - AROUND] & (spread(whole)[AROUND - 1 : n - AROUND - 1] < SPREAD)
    return [(int(t) + AROUND + 1, float(ratio[t])) for t in np.flatnonzero(hit)][:5]


def spread(step: Array) -> Array:
    """Per step but the first and last: how unevenly the dimensions stepped further than on their neighbouring
    steps (the largest ratio over the median, over the dimensions moving there by more than `MOVED`). Frames
    lost carry every moving dimension further by the same factor; one dimension jumping alone (a teleport) is
    far beyond the others. 1 with fewer than two such dimensions (nothing to compare)."""
    near = (np.abs(step[:-2]) + np.abs(step[2:])) / 2
    moved = near > MOVED
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a step with no dimension moving: NaN, then 1
        r = np.where(moved, np.abs(step[1:-1]) / near, np.nan)
        out = np.nanmax(r, axis=1, initial=-np.inf) / np.nanmedian(np.where(moved, r, np.nan), axis=1)
    return np.where(moved.sum(axis=1) >= 2, np.nan_to_num(out, nan=1.0, posinf=np.inf), 1.0)


def step_ratios(z: Array, late: npt.NDArray[np.bool_], drops: list[int]) -> Array:
    """Per frame: the state's step onto it (`z`, range units; the norm over its dimensions) over the median of the
    `AROUND` steps either side; 0 where that median is 0 (nothing moving), at the episode's first and last
    `AROUND` frames, on a late timestamp (`late`: a `gap`) and within `AROUND` frames of a drop the rows found
    (`drops`). `cuts.picture_drops` reads it: frames lost step further than their neighbours, if less than
    `drop_factor` where the arm starts, stops or turns."""
    out = np.zeros(len(z))
    n = len(z) - 1  # steps
    if n < 2 * AROUND + 1 or z.shape[1] == 0:
        return out
    with np.errstate(all="ignore"):
        norm = np.linalg.norm(np.nan_to_num(np.diff(z, axis=0), posinf=0.0, neginf=0.0), axis=1)
        near = np.stack([norm[AROUND + d : n - AROUND + d] for d in range(-AROUND, AROUND + 1) if d])
        median = np.median(near, axis=0)
        ratio = np.where(median > 0, norm[AROUND : n - AROUND] / np.where(median > 0, median, 1.0), 0.0)
    out[AROUND + 1 : n - AROUND + 1] = np.where(late[AROUND : n - AROUND], 0.0, ratio)
    for f in drops:
        out[max(0, f - AROUND) : f + AROUND + 1] = 0.0
    return out


def frame_drop_findings(drops: list[tuple[int, float]], th: Thresholds) -> list[Finding]:
    detail = "a step beyond its neighbours', timestamps even"
    return [Finding("frame_drop", "observation.state", f, f, r, th.drop_factor, detail=detail) for f, r in drops]


def repeated_rows(arrays: list[Array], z: Array, th: Thresholds) -> list[Finding]:
    """`repeated_rows`: 1 to `repeat_max` frames whose state and action (`arrays`) repeat the frame before bit for
    bit, between frames where the state (`z`, range units) moves: a row written again (the copies' frames). At
    most `REPEATS` such places: a recorder whose sensors update slower than its rate repeats rows all along (its
    nature, which a policy trained on it sees everywhere), a row written twice by mistake is rare."""
    n = len(z)
    if n < 4 or not arrays:
        return []
    same = np.ones(n - 1, dtype=bool)
    for x in arrays:
        same &= (x[1:] == x[:-1]).all(axis=1)
    moved = np.zeros(n, dtype=bool)  # moved[t]: the state changed from frame t - 1 to t
    moved[1:] = np.nan_to_num(np.abs(np.diff(z, axis=0))).max(axis=1, initial=0.0) > 0
    out = []
    for a, b in runs(same):
        first, last = a + 1, b + 1  # frames repeating the one before
        if last - first + 1 <= th.repeat_max and first >= 2 and last + 1 < n and moved[first - 1] and moved[last + 1]:
            out.append(Finding("repeated_rows", "episode", first, last, float(last - first + 1), float(th.repeat_max)))
    return out if len(out) <= REPEATS else []


def degrees(x: Array, names: list[str], feature: str, th: Thresholds) -> list[Finding]:
    """`degrees`: an angle-named dimension (`signals.ANGLE_NAME`) whose values go beyond ±`degrees_limit` (2π +
    0.5 rad) while the feature's other dimensions look like radians or metres (the median of their largest
    magnitudes within ±π): no angle in radians goes there; one in degrees does as soon as it turns past 7°. A
    dataset written in degrees throughout (LeRobot's Feetech arms) is its own convention, not this fault. The
    whole episode; value: its largest magnitude."""
    n = len(x)
    if not n:
        return []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a column of NaN
        top = np.nan_to_num(np.nanmax(np.abs(np.where(np.isfinite(x), x, np.nan)), axis=0))
    out = []
    for d, name in enumerate(names):
        others = np.delete(top, d)
        if signals.ANGLE_NAME.search(name) and top[d] > th.degrees_limit and float(np.median(others)) <= math.pi:
            detail = "beyond 2π: degrees?"
            out.append(
                Finding("degrees", dim_subject(feature, name), 0, n - 1, float(top[d]), th.degrees_limit, detail=detail)
            )
    return out
