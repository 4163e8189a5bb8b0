"""Per-dimension faults of one episode: dimensions frozen to the end, clipping plateaus, gripper chatter."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

Array = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Frozen:
    feature: str
    dim: int
    name: str
    from_frame: int


def last_change(x: Array) -> npt.NDArray[np.int64]:
    """Per dimension of `x` (frames, dims): the first frame of its final constant run (0: constant throughout)."""
    n, d = x.shape
    if n < 2:
        return np.zeros(d, dtype=np.int64)
    changed = x[1:] != x[:-1]  # NaN != NaN: a NaN run is no frozen value
    idx = np.where(changed, np.arange(1, n)[:, None], 0)
    return np.asarray(idx.max(axis=0), dtype=np.int64)


def frozen_dims(
    feature: str, x: Array, names: list[str], varies: npt.NDArray[np.bool_], min_frames: int, min_share: float
) -> list[Frozen]:
    """Dimensions that vary in the dataset (`varies`) but hold one value from some frame to the episode's end,
    for at least `min_frames` frames and `min_share` of it, while another dimension of `feature` still moves
    after that frame (when every dimension rests, the episode is idle, not a dimension dead)."""
    n = x.shape[0]
    if n < 2:
        return []
    starts = last_change(x)
    need = max(min_frames, int(np.ceil(min_share * n)))
    out = []
    for d in np.flatnonzero(varies):
        j = int(starts[d])
        if n - j < need:
            continue
        others = [o for o in np.flatnonzero(varies) if o != d]
        if any(starts[o] > j for o in others):
            out.append(Frozen(feature, int(d), names[d], j))
    return out


def clip_fraction(x: Array, lo: Array, hi: Array, skip: set[int], plateau: int) -> float | None:
    """Share of frames where some dimension (not in `skip`, varying in the dataset) sits on its observed min or
    max for at least `plateau` frames in a row; None without such dimensions."""
    n, d = x.shape
    dims = [i for i in range(d) if i not in skip and hi[i] > lo[i]]
    if not dims or n == 0:
        return None
    clipped = np.zeros(n, dtype=bool)
    for i in dims:
        for limit in (lo[i], hi[i]):
            clipped |= _runs_at_least(x[:, i] == limit, plateau)
    return float(clipped.mean())


def _runs_at_least(mask: npt.NDArray[np.bool_], k: int) -> npt.NDArray[np.bool_]:
    """`mask` kept only where it belongs to a run of at least `k` True values."""
    out = np.zeros_like(mask)
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True):
        if b - a >= k:
            out[a:b] = True
    return out


def gripper_dims(names: list[str]) -> list[int]:
    """The dimensions whose name contains "gripper" (any case)."""
    return [i for i, name in enumerate(names) if "gripper" in name.lower()]


def toggles(x: Array, lo: float, hi: float) -> int:
    """How often `x` crosses between the lower and upper third of [lo, hi] (a hysteresis band, so noise around
    the middle is not counted)."""
    if not hi > lo:
        return 0
    low, high = lo + (hi - lo) / 3, hi - (hi - lo) / 3
    count, side = 0, 0  # side: -1 low, +1 high, 0 not yet known
    for v in x:
        new = -1 if v <= low else 1 if v >= high else side
        if side and new != side:
            count += 1
        side = new
    return count
