"""A camera out of step with the state and the other cameras (`camera_lag`) (docs/stats.md, "Quality").

A camera whose frames are paired with rows k frames late shows, where the arm starts moving, k more frames of the
still scene than the state and the in-step cameras do: the state moves, the other cameras' pictures change, and
its picture repeats exactly (a still scene decodes as copies). Only the first frames are decoded again, at the
full frame rate (the stride-sampled pass cannot place 2-3 frames): up to `LAG_MAX` + 1 frames after the arm's
first motion. Measured where the motion *starts*, because there the change of a still picture is unambiguous; a
correlation of the cameras' change with the state's speed over the whole episode peaked at spurious lags of ±8
frames on clean 40-70-frame episodes (benchmarks/README.md, "Quality calibration"). A camera that never shows a
still scene at the start (sensor noise, or a robot already moving at frame 0) is in step as far as this check can
tell.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from openral_data.metrics.quality.edges import Full
from openral_data.metrics.quality.findings import Finding

LAG_MIN = 2  # frames: a camera starting this many frames or more after the scene is out of step (in step: 0-1)
LAG_MAX = 8  # ... and at most this many: a longer still start while the arm moves is a frozen camera's
IN_STEP = 1  # the other cameras must start within this many frames of the scene (a codec's copy: 1)
START_MAX = 30  # the arm must start moving by this frame (no long decode for an idle head)


def motion_start(moving: npt.NDArray[np.bool_]) -> int | None:
    """The first frame (from 1) where the arm moves; None without one by `START_MAX` (frame 0's speed is frame
    1's: `motion.speeds`)."""
    at = np.flatnonzero(moving[1 : START_MAX + 1])
    return int(at[0]) + 1 if len(at) else None


def camera_lags(cameras: dict[str, Full], moving: npt.NDArray[np.bool_] | None, length: int) -> list[Finding]:
    """`camera_lag`: a camera whose picture starts changing `LAG_MIN`..`LAG_MAX` frames after the scene starts
    moving (the earlier of the arm's first motion, `motion_start`, and the other cameras' first change), the arm
    moving by then, when every other camera's picture starts within `IN_STEP` frames of it; the finding spans the
    episode (the pairing is off throughout), its value the frames it trails by."""
    if moving is None or (start := motion_start(moving)) is None:
        return []
    count = start + LAG_MAX + 1
    starts = {key: full.first_change(count) for key, full in cameras.items()}
    out: list[Finding] = []
    for key, first in starts.items():
        others = [v for k, v in starts.items() if k != key]
        ref = min([start, *(v for v in others if v is not None)])
        lag = (count if first is None else first) - ref
        in_step = all(v is not None and v - ref <= IN_STEP for v in others)
        if LAG_MIN <= lag <= LAG_MAX and start <= ref + lag and in_step:
            detail = f"its picture starts changing {lag} frames after the scene (frame {ref}"
            detail += ": the arm and the other cameras)" if others else ": the arm)"
            out.append(Finding("camera_lag", key, 0, length - 1, float(lag), float(LAG_MIN), detail=detail))
    return out
