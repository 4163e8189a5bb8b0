"""Whether a camera shows what the others and the state show, each a list of `Finding`s: a camera turned upside
down against the dataset's other episodes of that camera (`camera_flipped`) and a camera out of step with the
state's motion or the episode's other cameras (`camera_lag`) (docs/stats.md, "Quality").

Each camera's sampled frames leave a `THUMB` x `THUMB` mean luma picture per episode (a few hundred bytes): an
episode whose picture matches the other episodes' median picture better turned 180° than as it is was filmed
upside down; no reference file is needed, only that most episodes are the right way up.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from openral_data.metrics.quality.findings import Finding

Array = npt.NDArray[np.float64]
Gray = npt.NDArray[np.float32]
THUMB = 16  # side of an episode's mean picture
MIN_EPISODES = 3  # episodes of one camera needed to tell which way is up
LOO_MAX = 64  # up to this many episodes each is compared with the median of the others; beyond, of all
MAX_LAG = 8  # frames a camera is searched behind / ahead of the state
FOLLOWS = 0.6  # a camera whose change correlates less with the state's motion says nothing about its lag


def thumbnail(gray: Gray) -> Gray:
    """`gray` averaged down to `THUMB` x `THUMB` (point-sampled when smaller)."""
    h, w = gray.shape
    if h < THUMB or w < THUMB:
        ys, xs = (np.arange(THUMB) * h) // THUMB, (np.arange(THUMB) * w) // THUMB
        return np.asarray(gray[np.ix_(ys, xs)], dtype=np.float32)
    hh, ww = h // THUMB * THUMB, w // THUMB * THUMB
    return np.asarray(gray[:hh, :ww].reshape(THUMB, hh // THUMB, THUMB, ww // THUMB).mean(axis=(1, 3)), np.float32)


def standard(x: Gray) -> Array:
    v = x.astype(np.float64).ravel()
    v -= v.mean()
    norm = float(np.linalg.norm(v))
    return v / norm if norm > 0 else v


def flipped(thumbs: dict[int, Gray], camera: str, lengths: dict[int, int], margin: float) -> dict[int, list[Finding]]:
    """`camera_flipped`: per episode (`thumbs`: its mean picture of `camera`), the correlation with the other
    episodes' median picture turned 180° minus as it is, when above `margin`; the whole episode."""
    if len(thumbs) < MIN_EPISODES:
        return {}
    order = sorted(thumbs)
    stack = np.stack([thumbs[e] for e in order])
    whole = np.median(stack, axis=0)
    out: dict[int, list[Finding]] = {}
    for k, e in enumerate(order):
        ref = standard(np.median(np.delete(stack, k, axis=0), axis=0) if len(order) <= LOO_MAX else whole)
        mine = thumbs[e]
        gain = float(standard(mine[::-1, ::-1]) @ ref - standard(mine) @ ref)
        if gain > margin:
            n = lengths.get(e, 1)
            detail = "matches the other episodes turned 180°"
            out[e] = [Finding("camera_flipped", camera, 0, n - 1, gain, margin, detail=detail)]
    return out


def camera_lag(changes: list[float | None], speed: Array, stride: int) -> tuple[int, float]:
    """The lag (frames) at which the camera's change between samples best follows the state's motion over the
    same frames (`speed`: per frame), and that correlation; (0, 0.0) with too few samples or no motion."""
    c = np.array([v for v in changes[1:] if v is not None], dtype=np.float64)
    if len(c) < 8 or len(c) != len(changes) - 1:
        return 0, 0.0
    total = np.concatenate([[0.0], np.cumsum(np.nan_to_num(speed))])
    frames = np.arange(1, len(c) + 1) * stride
    best = (0, -1.0)
    for lag in range(-MAX_LAG, MAX_LAG + 1):
        hi = np.clip(frames - lag + 1, 0, len(speed))
        lo = np.clip(frames - stride - lag + 1, 0, len(speed))
        m = total[hi] - total[lo]
        if m.std() == 0 or c.std() == 0:
            continue
        corr = float(np.corrcoef(c, m)[0, 1])
        if corr > best[1]:
            best = (lag, corr)
    return best


def lag_findings(lags: dict[str, tuple[int, float]], n: int, limit: int) -> list[Finding]:
    """`camera_lag`: a camera whose picture changes more than `limit` frames before or after the state moves
    (cameras whose change does not follow the state at all, correlation under `FOLLOWS`, left out)."""
    out = []
    for key, (lag, corr) in lags.items():
        if corr >= FOLLOWS and abs(lag) > limit:
            detail = f"its picture changes {lag} frames after the state moves"
            out.append(Finding("camera_lag", key, 0, n - 1, float(lag), float(limit), detail=detail))
    return out
