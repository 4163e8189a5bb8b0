"""Whether one episode's action drives its state as it should, each a list of `Finding`s: two action dimensions
swapped (`action_swap`) and the action shifted in time against the state (`action_lag`) (docs/stats.md,
"Quality").

An action dimension is paired with the state dimension its name names (`partners`): the same name, or the same
words once the generic ones are dropped (`delta_x` and `eef_x`, `joint_0_vel` and `joint_0`, `action_3` and
`observation.state_3`). Its command is the action itself when it is a velocity or a delta (`delta`/`vel` in its
name), else its change per frame; the state's response is its partner's change per frame. Both are compared by
correlation, `MAX_LAG` frames either way.
"""

from __future__ import annotations

import re

import numpy as np
import numpy.typing as npt

from openral_data.metrics.quality.findings import Finding, dim_subject
from openral_data.metrics.quality.thresholds import Thresholds

Array = npt.NDArray[np.float64]
GENERIC = {
    "delta",
    "vel",
    "velocity",
    "pos",
    "position",
    "action",
    "observation",
    "state",
    "eef",
    "ee",
    "hand",
    "joint",
    "cmd",
    "target",
}
VELOCITY = re.compile(r"delta|vel", re.IGNORECASE)
MAX_LAG = 15  # frames the action is searched ahead of / behind the state
MIN_FRAMES = 30  # fewer frames: too few to correlate
# `action_swap`: each of two dimensions follows the other's partner this much better than its own. In clean
# episodes no pair does (the largest margin, calibration corpus: 0.00, a joint sweep moving two joints alike);
# swapped, Meta-World's diagonal motions follow each other's partner by 0.06-0.2 (benchmarks/README.md)
SWAP_MARGIN = 0.05
# `action_swap` of position targets: each this many times nearer the other's state than its own (calibration
# corpus, tuning half: clean at most 1.0, a joint sweep's joints near one angle; swapped 5.8 and more)
LEVEL = 3.0
WEAK = 0.3  # a pair correlating less than this at its best lag: the action does not drive that state
STRONG = 0.6  # `action_swap`: ... while the other pairs correlate at least this (median)


def words(name: str) -> tuple[str, ...]:
    return tuple(w for w in re.split(r"[^a-z0-9]+", name.lower()) if w and w not in GENERIC)


def partners(action_names: list[str], state_names: list[str]) -> dict[int, int]:
    """Action dimension -> the state dimension its name names (one state dimension per word set); the gripper
    left out (a command to open or close, not a motion the state follows step by step)."""
    index: dict[tuple[str, ...], list[int]] = {}
    for j, name in enumerate(state_names):
        index.setdefault(words(name), []).append(j)
    out = {}
    for i, name in enumerate(action_names):
        found = index.get(words(name), [])
        if words(name) and len(found) == 1 and "gripper" not in name.lower():
            out[i] = found[0]
    return out


def standard(a: Array) -> Array:
    """`a` minus its mean over its norm (zeros when constant or not finite)."""
    if not np.isfinite(a).all():
        return np.zeros_like(a)
    a = a - a.mean()
    norm = float(np.sqrt((a * a).sum()))
    return a / norm if norm > 0 else a


def cross(a: Array, b: Array, max_lag: int) -> Array:
    """The correlation of a[t] with b[t + lag] for lag -max_lag..max_lag (both standardised over the whole
    episode once; one FFT, so linear-logarithmic in the episode's length)."""
    n = len(a)
    size = 1 << (2 * n - 1).bit_length()
    full = np.fft.irfft(np.conj(np.fft.rfft(standard(a), size)) * np.fft.rfft(standard(b), size), size)
    lags = np.arange(-max_lag, max_lag + 1)
    return np.asarray(np.where(np.abs(lags) < n, full[lags % size], 0.0), dtype=np.float64)


def commands(action: Array, names: list[str]) -> Array:
    """Per action dimension, what the state's change per frame should follow (row t: the step from t to t+1)."""
    step = np.diff(action, axis=0)
    out = action[:-1].copy()
    for i, name in enumerate(names):
        if not VELOCITY.search(name):
            out[:, i] = step[:, i]
    return out


def target_steps(action: Array, names: tuple[list[str], list[str]], dims: list[int], scale: Array) -> Array:
    """(frames - 1, len(dims)): per state dimension in `dims`, the |step| of its position target (the action
    dimension `partners` pairs with it, no `delta`/`vel` in its name: in the state's units) over `scale` (the
    state dimension's range); 0 without one."""
    out = np.zeros((max(len(action) - 1, 0), len(dims)))
    targets = {j: i for i, j in partners(*names).items() if not VELOCITY.search(names[0][i])}
    for k, j in enumerate(dims):
        if j in targets and scale[j] > 0:
            with np.errstate(invalid="ignore", over="ignore"):  # a NaN/Inf command (the `non_finite` fault)
                out[:, k] = np.nan_to_num(np.abs(np.diff(action[:, targets[j]])) / scale[j], nan=0.0)
    return out


def alignment(action: Array, state: Array, names: tuple[list[str], list[str]], th: Thresholds) -> list[Finding]:
    """`action_swap` and `action_lag` of one episode (`names`: the action's and the state's dimension names)."""
    n = len(action)
    pairs = {i: j for i, j in partners(*names).items() if np.ptp(state[:, j]) > 0 and np.ptp(action[:, i]) > 0}
    if n < MIN_FRAMES or not pairs:
        return []
    cmd, response = commands(action, names[0]), np.diff(state, axis=0)
    best: dict[int, tuple[float, int]] = {}  # action dim -> (best correlation with its partner, at that lag)
    for i, j in pairs.items():
        scores = cross(cmd[:, i], response[:, j], MAX_LAG)
        k = int(np.argmax(scores))
        best[i] = (float(scores[k]), k - MAX_LAG)
    common = round(float(np.median([lag for _, lag in best.values()])))
    found = swaps(cmd, response, pairs, common, names[0])
    said = {f.subject for f in found}
    found += [f for f in level_swaps(action, state, pairs, names[0]) if f.subject not in said]
    return found + lag_findings(best, n, th, names[0])


def level_swaps(action: Array, state: Array, pairs: dict[int, int], names: list[str]) -> list[Finding]:
    """`action_swap` of two position commands (no `delta`/`vel` in their names: a target in the state's units),
    each lying `LEVEL` times nearer the other's partner than its own (median absolute difference over the
    episode). Joints commanded alike (a sweep moving them along one curve) swap no change a correlation could
    see, but their targets sit at the other joint's angle."""
    level = [i for i in pairs if not VELOCITY.search(names[i])]
    out: dict[int, Finding] = {}
    for i in level:
        own = float(np.median(np.abs(action[:, i] - state[:, pairs[i]])))
        for k in level:
            if k == i:
                continue
            near_i = float(np.median(np.abs(action[:, i] - state[:, pairs[k]])))
            near_k = float(np.median(np.abs(action[:, k] - state[:, pairs[i]])))
            mine_k = float(np.median(np.abs(action[:, k] - state[:, pairs[k]])))
            if own > LEVEL * near_i and mine_k > LEVEL * near_k:
                detail = f"lies nearer {names[k]}'s state than its own ({near_i:.3g} against {own:.3g})"
                out[i] = Finding(
                    "action_swap",
                    dim_subject("action", names[i]),
                    0,
                    len(action) - 1,
                    own / near_i if near_i > 0 else float("inf"),
                    LEVEL,
                    detail=detail,
                )
                break
    return [out[i] for i in sorted(out)]


def swaps(cmd: Array, response: Array, pairs: dict[int, int], lag: int, names: list[str]) -> list[Finding]:
    """`action_swap`, every pair compared at the episode's lag (`lag`): an action dimension that does not drive
    its partner (correlation under `WEAK`) while the episode's other paired dimensions do (their median at least
    `STRONG`), or two dimensions each following the other's partner better than their own by `SWAP_MARGIN`: it
    carries another dimension's command (two columns swapped, or mislabelled)."""
    n = len(cmd) + 1
    shift = {i: np.roll(standard(response[:, j]), -lag) for i, j in pairs.items()}  # partner's, lag frames on
    unit = {i: standard(cmd[:, i]) for i in pairs}
    own = {i: float(unit[i] @ shift[i]) for i in pairs}
    out: dict[int, Finding] = {}
    for i in pairs:
        others = [corr for k, corr in own.items() if k != i]
        if len(others) >= 2 and own[i] < WEAK and float(np.median(others)) >= STRONG:
            detail = f"correlates {own[i]:.2f} with its state while the others {float(np.median(others)):.2f}"
            out[i] = Finding("action_swap", dim_subject("action", names[i]), 0, n - 1, own[i], WEAK, detail=detail)
        for k in pairs:
            if k == i or i in out:
                continue
            cross_i, cross_k = float(unit[i] @ shift[k]), float(unit[k] @ shift[i])
            if min(cross_i - own[i], cross_k - own[k]) > SWAP_MARGIN:
                detail = f"follows {names[k]}'s state better than its own ({cross_i:.2f} against {own[i]:.2f})"
                out[i] = Finding("action_swap", dim_subject("action", names[i]), 0, n - 1, own[i], WEAK, detail=detail)
    return [out[i] for i in sorted(out)]


def lag_findings(best: dict[int, tuple[float, int]], n: int, th: Thresholds, names: list[str]) -> list[Finding]:
    """`action_lag`: the state following the action (its pairs correlating at least `WEAK`, their median best
    lag) more than `action_lag_frames` frames later or earlier than at once (row t: the action at t, or its step
    to t + 1, against the state's step from t to t + 1); `velocity_lag_frames` when every such pair is a
    velocity/delta command (`names`: the action's), which the state follows at once (its controller integrates
    it), not through a follower's servo that trails a position target."""
    strong = {i: lag for i, (corr, lag) in best.items() if corr >= WEAK}
    if not strong:
        return []
    lag = float(np.median(list(strong.values())))
    velocity = all(VELOCITY.search(names[i]) for i in strong)
    limit = th.velocity_lag_frames if velocity else th.action_lag_frames
    if abs(lag) <= limit:
        return []
    detail = f"the state follows the action {lag:g} frames later"
    return [Finding("action_lag", "action", 0, n - 1, lag, float(limit), detail=detail)]
