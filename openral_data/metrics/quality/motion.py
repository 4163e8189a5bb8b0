"""Idle frames and smoothness of one episode's state/action trajectories (in dataset-range units)."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]


# a dimension whose dataset range is under this share of its magnitude (at least 1) holds still: what it moves is
# rounding residue (a generated episode's rotation deltas about x and y: ±2e-31 rad where its source commands 0)
RESIDUE = 1e-9


def varies(lo: Array, hi: Array) -> npt.NDArray[np.bool_]:
    """Per dimension, whether its range `lo`..`hi` is more than rounding residue (`RESIDUE`)."""
    return np.asarray((hi - lo) > RESIDUE * np.fmax(1.0, np.fmax(np.abs(lo), np.abs(hi))), dtype=bool)


def normalised(x: Array, lo: Array, hi: Array) -> Array:
    """`x` (frames, dims) in units of each dimension's dataset range; constant dimensions (`varies`) are dropped."""
    moving = varies(lo, hi)
    return (x[:, moving] - lo[moving]) / (hi - lo)[moving]


def speeds(z: Array, fps: int) -> Array:
    """Per frame: the largest per-dimension change since the previous frame, in range per second; frame 0 takes
    frame 1's (NaN values are ignored)."""
    n = z.shape[0]
    if n < 2 or z.shape[1] == 0:
        return np.zeros(n)
    with np.errstate(all="ignore"):
        step = np.abs(np.diff(z, axis=0))
        s = np.where(np.isnan(step), 0.0, step).max(axis=1) * fps
    return np.concatenate([s[:1], s])


def idle_frames(
    state_speed: Array | None, action_speed: Array | None, n: int, threshold: float
) -> npt.NDArray[np.bool_]:
    """Frames where every given speed is under `threshold`."""
    idle = np.ones(n, dtype=bool)
    for s in (state_speed, action_speed):
        if s is not None:
            idle &= s < threshold
    return idle


def run_lengths(idle: npt.NDArray[np.bool_]) -> tuple[int, int]:
    """Idle frames at the head and at the tail (both the whole episode when every frame is idle)."""
    n = len(idle)
    moving = np.flatnonzero(~idle)
    if len(moving) == 0:
        return n, n
    return int(moving[0]), int(n - 1 - moving[-1])


def ldlj(z: Array, fps: int) -> float | None:
    """Log dimensionless jerk of the speed profile, -ln(T^3 / v_peak^2 * integral |d2v/dt2|^2 dt) (Balasubramanian
    et al. 2015); None for fewer than 4 frames, no motion or no jerk at all. Higher (closer to 0) is smoother."""
    n = z.shape[0]
    if n < 4 or z.shape[1] == 0 or not np.isfinite(z).all():
        return None
    v = np.diff(z, axis=0) * fps
    peak = float(np.sqrt((v**2).sum(axis=1)).max())
    if peak <= 0:
        return None
    jerk = np.diff(v, n=2, axis=0) * fps * fps
    integral = float((jerk**2).sum()) / fps
    duration = (n - 1) / fps
    dlj = duration**3 / peak**2 * integral
    return -math.log(dlj) if dlj > 0 else None  # no jerk at all (constant velocity)


def windowed_ldlj(z: Array, fps: int, window_s: float) -> float | None:
    """The median `ldlj` over consecutive windows of `window_s` seconds (at least 4 frames; a shorter episode is
    one window). LDLJ falls with a movement's length and its number of sub-movements, so an episode's whole
    trajectory would rate long demonstrations jerky; windows of one length make episodes comparable."""
    k = max(4, round(window_s * fps))
    spans = [(a, a + k) for a in range(0, len(z) - k + 1, k)] or [(0, len(z))]
    values = [v for a, b in spans if (v := ldlj(z[a:b], fps)) is not None]
    return float(np.median(values)) if values else None


def reversals(z: Array, tol: float) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.bool_]]:
    """(frames, dims) of `z` in range units: at frame t, whether the step into t and the step out of it both
    exceed `tol` (`counted`) and point opposite ways (`reversed`). Noise reverses at about every other frame;
    smooth motion, a scripted straight line or a step to a new set point only where it turns back."""
    n, d = z.shape
    counted = np.zeros((n, d), dtype=bool)
    back = np.zeros((n, d), dtype=bool)
    if n >= 3:
        with np.errstate(invalid="ignore"):
            step = np.diff(z, axis=0)
            big = np.abs(step) > tol
            counted[1:-1] = big[:-1] & big[1:]
            back[1:-1] = counted[1:-1] & (np.sign(step[:-1]) != np.sign(step[1:]))
    return counted, back


def jerky_windows(
    z: Array, fps: int, window_s: float, tol: float, min_reversals: int
) -> list[tuple[int, int, int, float]]:
    """Per dimension of `z`, the windows of `window_s` seconds (at least 4 frames) holding at least
    `min_reversals` reversals: (dim, first frame, last frame, the share of its counted frames that reverse)."""
    counted, back = reversals(z, tol)
    n, k = z.shape[0], max(4, round(window_s * fps))
    out = []
    for a in range(0, max(n - k // 2, 1), k):
        b = min(a + k, n)
        c, r = counted[a:b].sum(axis=0), back[a:b].sum(axis=0)
        for dim in np.flatnonzero(r >= min_reversals):
            out.append((int(dim), a, b - 1, float(r[dim] / c[dim])))
    return out
