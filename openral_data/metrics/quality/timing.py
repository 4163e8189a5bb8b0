"""Timestamp regularity of one episode: jitter and gaps, in frame periods."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt


def timestamp_steps(timestamps: npt.NDArray[np.float64], fps: int) -> npt.NDArray[np.float64]:
    """Each step between consecutive frames (in frame_index order), in frame periods (1.0 is on time)."""
    return np.diff(timestamps) * fps


def gaps(steps: npt.NDArray[np.float64], gap_frames: float) -> int:
    """Steps longer than `gap_frames` periods, or not forward at all."""
    return int(((steps > gap_frames) | (steps <= 0)).sum())


def jitter(steps: npt.NDArray[np.float64], gap_frames: float) -> float:
    """The largest deviation of a step from one period, gaps aside (0.0 when there is no other step)."""
    ok = steps[(steps <= gap_frames) & (steps > 0)]
    return float(np.abs(ok - 1.0).max()) if len(ok) else 0.0
