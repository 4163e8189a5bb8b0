"""Hidden frame drops where a scripted motion starts (`frame_drop`, docs/stats.md "Quality"): the state moving
before its command.

A scripted controller's command starts from rest (a delta of exactly 0, a position target held) and the state
follows it at once or later (`alignment`: the command's row t drives the state's step from t to t + 1). Frames
lost where a motion started take the motion's first, slow steps with them: the state's step onto the command's
first frame is then already as long as the motion's steps after it, while the command before it was at rest.
Neither the rows' rule (`rows.frame_drops`: one long step between moving ones) nor the pictures' (`cuts`: the
step beyond its neighbours') sees it: the arm was still before the cut and moves on at its usual speed after.
A person's command does not start from rest (a stick, a leader arm: they tremble and lead in), so the check runs
where the thresholds set a `lead_factor`: on scripted data (`thresholds.KINDS`).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from numpy.lib.stride_tricks import sliding_window_view

from openral_data.formats.lerobot_v3.features import STATE
from openral_data.metrics.quality import alignment
from openral_data.metrics.quality.findings import Finding, dim_subject

Array = npt.NDArray[np.float64]
# a command at rest: under `QUIET` times its dimension's typical magnitude (the 75th percentile of its nonzero
# |command|) for `REST` frames; then starting: at least `ONSET` times it
QUIET = 0.05
ONSET = 0.3
REST = 2
CRUISE = 4  # the state's steps after the onset that make the motion's speed once commanded
# the state's step onto the onset at least this many times its larger step on the 2 frames before it (the arm
# settling after the last motion moves a little while its command rests; calibration corpus: 5.7 and more where
# frames were lost, a person's joint velocity 4.4)
SETTLE = 3.0
MOST = 5  # drops kept per episode (as `rows.frame_drops`)
OFF = 1e9  # a `lead_factor` this large: the check does not run (`thresholds.Thresholds.lead_factor`)


def frame_drops(
    action: Array, state: Array, names: tuple[list[str], list[str]], late: npt.NDArray[np.bool_], factor: float
) -> list[Finding]:
    """`frame_drop` at each frame where an action dimension's command starts from rest (`alignment.commands`,
    paired by `alignment.partners`) and its state partner's step onto that frame, in the command's direction, is
    already `factor` times the median of its `CRUISE` steps after and `SETTLE` times its steps on the `REST`
    frames before; not on a late timestamp (`late`, per step: a `gap`). About the state dimension; the
    value: the step over that median. At most `MOST`, the largest."""
    n = len(state)
    if factor >= OFF or n < REST + CRUISE + 2 or len(action) != n:
        return []
    if not (np.isfinite(action).all() and np.isfinite(state).all()):
        return []  # `non_finite` says so; a NaN command has no onset
    cmd, response = alignment.commands(action, names[0]), np.diff(state, axis=0)
    found: dict[int, tuple[float, int]] = {}  # frame -> (value, state dimension)
    for i, j in alignment.partners(*names).items():
        c, r = cmd[:, i], response[:, j]
        size = np.abs(c)
        if not (size > 0).any():
            continue
        typical = float(np.percentile(size[size > 0], 75))
        # rest[t]: command rows t .. t + REST - 1 at rest
        rest = np.asarray(sliding_window_view(size <= QUIET * typical, REST).all(axis=1), dtype=bool)
        # command row t starts (the state's step onto frame t is response row t - 1), CRUISE rows follow
        onset = np.zeros(len(c), dtype=bool)
        onset[REST + 1 : n - CRUISE] = (size >= ONSET * typical)[REST + 1 : n - CRUISE] & rest[1 : n - CRUISE - REST]
        for t in np.flatnonzero(onset & ~np.r_[False, late[: len(c) - 1]]).tolist():
            lead = float(r[t - 1] * np.sign(c[t]))
            cruise = float(np.median(np.abs(r[t : t + CRUISE])))
            before = float(np.abs(r[t - 1 - REST : t - 1]).max())
            if cruise > 0 and lead >= factor * cruise and lead >= SETTLE * before:
                value = lead / cruise
                if value > found.get(t, (0.0, 0))[0]:
                    found[t] = (value, j)
    kept = sorted(found, key=lambda t: -found[t][0])[:MOST]
    detail = "the state moving before its command starts, as far as the motion's steps after it: frames lost"
    return [
        Finding("frame_drop", dim_subject(STATE, names[1][found[t][1]]), t, t, found[t][0], factor, detail=detail)
        for t in sorted(kept)
    ]
