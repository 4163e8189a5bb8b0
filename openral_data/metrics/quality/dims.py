"""Per-dimension faults of one episode, each a list of `Finding`s with its frames: a state dimension frozen
while it should move, dimensions constant to the episode's end (informational), flat tops clipped at the
state's observed extremes, an action saturated at its extremes (informational), gripper chatter."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from openral_data.metrics.quality.findings import Finding, dim_subject, runs, span_findings

Array = npt.NDArray[np.float64]
Mask = npt.NDArray[np.bool_]


def held(x: Array) -> Mask:
    """(frames, dims): True at frame t when each dimension holds frame t-1's exact value (frame 0: False)."""
    same = x[1:] == x[:-1]  # NaN != NaN: a NaN run holds nothing
    return np.concatenate([np.zeros((1, x.shape[1]), dtype=bool), same], axis=0)


def constant_runs(column: Mask, min_frames: int) -> list[tuple[int, int]]:
    """Runs of one exact value at least `min_frames` frames long, (first, last) inclusive, from a `held` column
    (a run starts at the frame before its first held one)."""
    return [(a - 1, b) for a, b in runs(column, max(1, min_frames - 1))]


def moves(x: Array, a: int, b: int) -> Mask:
    """Per dimension: whether it takes more than one value over frames a..b."""
    part = x[a : b + 1]
    if not len(part):
        return np.zeros(x.shape[1], dtype=bool)
    return np.asarray(np.nanmax(part, axis=0) > np.nanmin(part, axis=0), dtype=bool)


USUAL_HELD = 0.5  # `frozen`: a dimension held on at most this share of its other frames normally changes


def flat_extreme(column: Array, a: int, b: int) -> bool:
    """Whether frames a..b of `column` (one value) are a flat top or bottom: entered and left from the same side."""
    if a == 0 or b >= len(column) - 1:
        return False
    before, after = np.sign(column[a - 1] - column[a]), np.sign(column[b + 1] - column[b])
    return bool(before == after != 0)


def frozen_state(
    x: Array,
    limits: tuple[Array, Array],
    names: list[str],
    varies: Mask,
    commands: dict[int, Array],
    lengths: tuple[int, int],
    feature: str,
) -> list[Finding]:
    """State dimensions (varying in the dataset, `varies`) that take more than one value in the episode and hold
    one exact value while they should move: the action dimension of the same name moved over that span
    (`commands`: state dim -> that action column), else, without one, another state dimension did. Held on a
    flat top or bottom (entered and left from the same side) for `lengths[0]` frames or more, inside the range, by
    a dimension that normally changes every frame (held on at most `USUAL_HELD` of its other frames): `clipped` (a
    limit the dataset's extremes do not show); else held `lengths[1]` frames or more by such a dimension and
    moving on from it by more than a count or two of its resolution (`caught_up`): `frozen`. A hand's or
    gripper's reading that holds most of the time (a slow sensor: a staircase) makes flat tops by nature. A sensor read
    by physics or an encoder never repeats itself bit for bit while the arm moves: a stale reading does; a hand
    dimension a person leaves still while the arm moves repeats itself most of the time. A value held on the
    dimension's observed min or max is a limit (`clipped` when a flat top, `at_extremes`), not a stale reading."""
    out: list[Finding] = []
    hold = held(x)
    clip_min, min_frames = lengths
    for d in np.flatnonzero(varies):
        spans: dict[str, list[tuple[int, int]]] = {"frozen": [], "clipped": []}
        for a, b in constant_runs(hold[:, d], min(lengths)):
            if (a == 0 and b == len(x) - 1) or x[a, d] in (limits[0][d], limits[1][d]):
                continue  # one value all along: unused in this episode (`constant`); on a limit: not stale
            command = commands.get(int(d))
            if command is not None:
                moving = bool(np.nanmax(command[a : b + 1]) > np.nanmin(command[a : b + 1]))
            else:
                moving = bool(moves(x, a, b)[[o for o in np.flatnonzero(varies) if o != d]].any())
            if not moving:
                continue
            if flat_extreme(x[:, d], a, b):
                if b - a + 1 >= clip_min and usually_changes(hold[:, d], a, b):
                    spans["clipped"].append((a, b))
            elif b - a + 1 >= min_frames and usually_changes(hold[:, d], a, b) and caught_up(x[:, d], b):
                spans["frozen"].append((a, b))
        subject = dim_subject(feature, names[d])
        for check, found in spans.items():
            longest = float(max((b - a + 1 for a, b in found), default=0))
            limit, detail = (min_frames, "held while moving") if check == "frozen" else (clip_min, "flat top")
            out += span_findings(check, subject, found, longest, float(limit), detail=detail)
    return out


COUNTS = 2.5  # `frozen`: a held reading that moves on by at most this many of the dimension's smallest steps


def caught_up(column: Array, b: int) -> bool:
    """Whether a reading held up to frame `b` moves on by more than `COUNTS` of the dimension's resolution (its
    smallest nonzero step in the episode): a stale reading, when it updates, jumps to where the joint went; an
    encoder's reading of a joint moving slower than one count per frame holds, then steps by a count or two. Held
    to the episode's end: nothing says which, stale."""
    if b + 1 >= len(column):
        return True
    steps = np.abs(np.diff(column))
    steps = steps[np.isfinite(steps) & (steps > 0)]
    return not len(steps) or bool(abs(column[b + 1] - column[b]) > COUNTS * float(steps.min()))


def usually_changes(column: Mask, a: int, b: int) -> bool:
    """Whether a `held` column holds on at most `USUAL_HELD` of its frames outside a..b."""
    others = len(column) - (b - a + 1)
    return others > 0 and float(column.sum() - column[a : b + 1].sum()) / others <= USUAL_HELD


def constant_tails(x: Array, names: list[str], varies: Mask, min_frames: int, feature: str) -> list[Finding]:
    """Informational: dimensions (varying in the dataset) constant from some frame to the episode's end for at
    least `min_frames` frames (from frame 0: unused in this episode). A task that does not use a dimension, or a
    scripted expert holding it, is no fault."""
    n = x.shape[0]
    out: list[Finding] = []
    if n < 2:
        return out
    hold = held(x)
    for d in np.flatnonzero(varies):
        changed = np.flatnonzero(~hold[1:, d])
        start = int(changed[-1]) + 1 if len(changed) else 0
        if n - start >= min_frames:
            out.append(
                Finding(
                    "constant", dim_subject(feature, names[d]), start, n - 1, float(n - start), float(min_frames), False
                )
            )
    return out


def plateaus(column: Array, limit: float, min_frames: int, interior: bool) -> list[tuple[int, int]]:
    """Runs of `column` exactly at `limit` for `min_frames` frames or more; `interior`: only those entered and
    left inside the episode (a flat top, not a rest at its start or end)."""
    found = runs(column == limit, min_frames)
    n = len(column)
    return [(a, b) for a, b in found if not interior or (a > 0 and b < n - 1)]


def at_extremes(
    x: Array, lo: Array, hi: Array, dims: list[int], min_frames: int, interior: bool
) -> dict[int, list[tuple[int, int]]]:
    """Per dimension in `dims`: its `plateaus` on its lower or upper limit."""
    found = {
        d: plateaus(x[:, d], lo[d], min_frames, interior) + plateaus(x[:, d], hi[d], min_frames, interior) for d in dims
    }
    return {d: sorted(s) for d, s in found.items() if s}


def changing(spans: dict[int, list[tuple[int, int]]], hold: Mask) -> dict[int, list[tuple[int, int]]]:
    """`spans` (per dimension) of the dimensions that normally change (`usually_changes` outside each span, `hold`
    from `held`): a reading that holds most of the time sits on its extremes by nature."""
    kept = {d: [(a, b) for a, b in found if usually_changes(hold[:, d], a, b)] for d, found in spans.items()}
    return {d: found for d, found in kept.items() if found}


def share_of(spans: dict[int, list[tuple[int, int]]], n: int) -> float:
    """The share of `n` frames inside any of `spans`."""
    covered = np.zeros(n, dtype=bool)
    for found in spans.values():
        for a, b in found:
            covered[a : b + 1] = True
    return float(covered.mean()) if n else 0.0


def gripper_dims(names: list[str]) -> list[int]:
    """The dimensions whose name contains "gripper" (any case)."""
    return [i for i, name in enumerate(names) if "gripper" in name.lower()]


def toggle_frames(x: Array, lo: float, hi: float) -> list[int]:
    """The frames where `x` crosses between the lower and upper third of [lo, hi] (a hysteresis band, so noise
    around the middle is not counted)."""
    if not hi > lo:
        return []
    low, high = lo + (hi - lo) / 3, hi - (hi - lo) / 3
    out, side = [], 0  # side: -1 low, +1 high, 0 not yet known
    for t, v in enumerate(x):
        new = -1 if v <= low else 1 if v >= high else side
        if side and new != side:
            out.append(t)
        side = new
    return out


def bursts(frames: list[int], gap: int, least: int = 3) -> list[tuple[int, int]]:
    """The runs of `frames` (toggle frames, in order) each within `gap` frames of the one before, with at least
    `least` of them: (first, last) frame."""
    out: list[tuple[int, int]] = []
    start = 0
    for i in range(1, len(frames) + 1):
        if i == len(frames) or frames[i] - frames[i - 1] > gap:
            if i - start >= least:
                out.append((frames[start], frames[i - 1]))
            start = i
    return out


def toggles(x: Array, lo: float, hi: float) -> int:
    return len(toggle_frames(x, lo, hi))
