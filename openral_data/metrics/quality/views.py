"""Whether a camera shows what the dataset's other episodes of that camera show: turned upside down
(`camera_flipped`) (docs/stats.md, "Quality").

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
# ... and turned it matches them at least this well: pictures of noise match nothing either way (two independent
# 16x16 noise pictures correlate with a standard deviation of 1/16: 0.25 is 4 of them); a scene whose objects
# move between episodes (a table filmed from above) matches its others' median 0.26-0.7 (benchmarks/README.md)
MATCH = 0.25
LOO_MAX = 64  # up to this many episodes each is compared with the median of the others; beyond, of all


def thumbnail(gray: Gray) -> Gray:
    """`gray` (H, W), or pictures of that size stacked (..., H, W), averaged down to `THUMB` x `THUMB`
    (point-sampled when smaller)."""
    *lead, h, w = gray.shape
    if h < THUMB or w < THUMB:
        ys, xs = (np.arange(THUMB) * h) // THUMB, (np.arange(THUMB) * w) // THUMB
        return np.asarray(gray[..., ys[:, None], xs], dtype=np.float32)
    hh, ww = h // THUMB * THUMB, w // THUMB * THUMB
    blocks = gray[..., :hh, :ww].reshape(*lead, THUMB, hh // THUMB, THUMB, ww // THUMB)
    return np.asarray(blocks.mean(axis=(-3, -1)), np.float32)


def standard(x: Gray) -> Array:
    v = x.astype(np.float64).ravel()
    v -= v.mean()
    norm = float(np.linalg.norm(v))
    return v / norm if norm > 0 else v


def flipped(thumbs: dict[int, Gray], camera: str, lengths: dict[int, int], margin: float) -> dict[int, list[Finding]]:
    """`camera_flipped`: per episode (`thumbs`: its mean picture of `camera`), the correlation with the other
    episodes' median picture turned 180° minus as it is, when above `margin` and turned it correlates at least
    `MATCH`; the whole episode."""
    if len(thumbs) < MIN_EPISODES:
        return {}
    order = sorted(thumbs)
    stack = np.stack([thumbs[e] for e in order])
    whole = np.median(stack, axis=0)
    out: dict[int, list[Finding]] = {}
    for k, e in enumerate(order):
        ref = standard(np.median(np.delete(stack, k, axis=0), axis=0) if len(order) <= LOO_MAX else whole)
        mine = thumbs[e]
        turned = float(standard(mine[::-1, ::-1]) @ ref)
        gain = turned - float(standard(mine) @ ref)
        if gain > margin and turned >= MATCH:
            n = lengths.get(e, 1)
            detail = "matches the other episodes turned 180°"
            out[e] = [Finding("camera_flipped", camera, 0, n - 1, gain, margin, detail=detail)]
    return out
