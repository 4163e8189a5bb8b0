"""Hidden frame drops the pictures show (`frame_drop`, docs/stats.md "Quality").

Frames lost while the timestamps stay even leave one long step between ordinary ones. Where the arm starts,
stops or turns between a script's waypoints the state's step alone cannot tell it from the script (the rows'
rule, `rows.frame_drops`, needs `drop_factor` times every neighbouring step), but the cameras film the lost
motion as one picture jump: a frame is a drop when a camera's picture changes `PICTURE` times as much as on any
of its `NEAR` frames either side (`jumps`) and the state's position steps onto it at least `STEP` times the
median of its neighbouring steps (`rows.step_ratios`, the quaternion aside: `rows.positions`). Each witness
alone is not enough: a clean script's waypoint makes the state step 4x its neighbours while the picture changes
as before, and a picture alone jumps where a door or an object moves on its own. The change is each camera's
per-frame mean absolute luma change (`edges.Full.change_at`, measured only at the frames `jumps` reads for a
candidate, `reach`); a frame a codec repeats (a copy, change under `edges.REPEAT`) is no neighbour, and its jump
shows one frame later (the drop is placed by the state's frame).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
import numpy.typing as npt
from numpy.lib.stride_tricks import sliding_window_view

from openral_data.metrics.quality.edges import REPEAT, Gray
from openral_data.metrics.quality.findings import Finding

Array = npt.NDArray[np.float64]
NEAR = 3  # frames either side whose picture change a jump is compared with
PICTURE = 1.8  # a camera's change this many times its largest neighbouring change (calibration: benchmarks/README.md)
STEP = 1.5  # ... while the state steps this many times the median of its neighbouring steps
MOST = 5  # drops kept per episode (as `rows.frame_drops`)


def jumps(change: Gray) -> Array:
    """Per frame: its picture change (`edges.Full.change`) over the largest change of the `NEAR` frames either
    side that are no copies; 0 for a copy, and where a side has no such frame (NaN or past either end: none).
    Frame t's value reads the change at frames t-NEAR .. t+NEAR alone."""
    c = np.asarray(change, dtype=np.float64)
    c = np.where(np.isfinite(c) & (c >= REPEAT), c, -np.inf)
    pad = np.full(NEAR, -np.inf)
    window = sliding_window_view(np.concatenate([pad, c, pad]), 2 * NEAR + 1)
    left, right = window[:, :NEAR].max(axis=1), window[:, NEAR + 1 :].max(axis=1)
    ok = np.isfinite(c) & np.isfinite(left) & np.isfinite(right)
    with np.errstate(all="ignore"):
        return np.where(ok, c / np.fmax(left, right), 0.0)


def reach(candidates: npt.NDArray[np.intp], n: int) -> list[int]:
    """The frames whose change `picture_drops` reads for frames `candidates` of `n`: `jumps` at t and t+1 reads
    t-NEAR .. t+1+NEAR."""
    return sorted({f for t in candidates.tolist() for f in range(max(0, t - NEAR), min(n, t + 2 + NEAR))})


def picture_drops(changes: Mapping[str, Callable[[Sequence[int]], Gray]], steps: Array) -> list[Finding]:
    """`frame_drop` at each frame where the state's step ratio (`steps`, `rows.step_ratios`) reaches `STEP` and
    some camera's picture jumps `PICTURE` times its neighbours' change (`jumps`) there or on the next frame (a
    copy at the cut); about that camera, the value its jump. At most `MOST`, the largest jumps. `changes`: per
    camera, its change at the frames given (`edges.Full.change_at`), asked for only at the frames these
    candidates' jumps read (`reach`) and only when some frame's step reaches `STEP`: the values elsewhere are
    never read."""
    n = len(steps)
    if not changes or not n or float(steps.max(initial=0.0)) < STEP:
        return []
    need = reach(np.flatnonzero(steps >= STEP), n)
    if not need:
        return []
    keys = sorted(changes)
    per = np.zeros((len(keys), n))
    for i, key in enumerate(keys):
        j = jumps(changes[key](need))[:n]
        per[i, : len(j)] = j
    at = np.maximum(per, np.concatenate([per[:, 1:], np.zeros((len(keys), 1))], axis=1))  # this frame or the next
    best = at.max(axis=0)
    hits = np.flatnonzero((steps >= STEP) & (best >= PICTURE))
    kept = sorted(hits, key=lambda t: -best[t])[:MOST]
    detail = f"a picture jump beyond its neighbours', the state stepping ≥ {STEP}x theirs, timestamps even"
    return [
        Finding("frame_drop", keys[int(at[:, t].argmax())], int(t), int(t), float(best[t]), PICTURE, detail=detail)
        for t in sorted(kept)
    ]


def explained(found: list[Finding], cameras: list[Finding]) -> list[Finding]:
    """`found` (the rows' findings) without the `teleport`s landing on a frame drop the pictures show among
    `cameras` (the camera pass's findings): frames lost carry every moving dimension on at once, as `teleports`
    leaves the rows' own drops aside."""
    cut = {f.start_frame for f in cameras if f.check == "frame_drop"}
    return [f for f in found if not (f.check == "teleport" and f.start_frame in cut)]
