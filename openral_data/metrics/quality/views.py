"""Whether a camera shows what the dataset's other episodes of that camera show: turned upside down
(`camera_flipped`) (docs/stats.md, "Quality").

Each camera's sampled frames leave three `THUMB` x `THUMB` pictures per episode (a few kilobytes, `MeanViews`): the
mean luma, the mean edges (|luma differences| to the neighbouring pixels) and where the picture moves (mean
|luma change| since the previous sample). An episode one of whose pictures matches the other episodes' median
picture better turned 180° than as it is was filmed upside down; no reference file is needed, only that most
episodes are the right way up. Three views because a scene can hide its way up from one of them: a bright table
between a dark arm above and a dark drawer below has a mean luma nearly the same turned (not its edges), a table
whose texture changes from episode to episode (a randomised scene) has neither a common luma nor common edges,
but the arm moves in the same place.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from openral_data.metrics.quality.findings import Finding

Array = npt.NDArray[np.float64]
Gray = npt.NDArray[np.float32]
THUMB = 16  # side of an episode's mean pictures
MIN_EPISODES = 3  # episodes of one camera needed to tell which way is up
VIEWS = ("mean picture", "edges", "motion")  # an episode's pictures, in the order `MeanViews.mean` stacks them
# ... and turned it matches them at least this well: pictures of noise match nothing either way (two independent
# 16x16 noise pictures correlate with a standard deviation of 1/16: 0.25 is 4 of them); a scene whose objects
# move between episodes (a table filmed from above) matches its others' median 0.26-0.7 (benchmarks/README.md).
# Where a camera on the arm sees motion differs more from one episode to the next (calibration corpus, tuning
# half: clean wrist cameras' motion pictures match the others' turned up to 0.30, a gain of 0.23 at 0.20): the
# motion picture must match them turned at least `MOTION_MATCH`
MATCH = 0.25
MOTION_MATCH = 0.5
LOO_MAX = 64  # up to this many episodes each is compared with the median of the others; beyond, of all


def thumbnail(gray: Gray) -> Gray:
    """`gray` (H, W), or pictures of that size stacked (..., H, W), averaged down to `THUMB` x `THUMB` over its
    centre (point-sampled when smaller): the thumbnail of a picture turned 180° is its thumbnail turned."""
    *lead, h, w = gray.shape
    if h < THUMB or w < THUMB:
        ys, xs = centred(h), centred(w)
        return np.asarray(gray[..., ys[:, None], xs], dtype=np.float32)
    hh, ww = h // THUMB * THUMB, w // THUMB * THUMB
    y0, x0 = (h - hh) // 2, (w - ww) // 2
    blocks = gray[..., y0 : y0 + hh, x0 : x0 + ww].reshape(*lead, THUMB, hh // THUMB, THUMB, ww // THUMB)
    return np.asarray(blocks.mean(axis=(-3, -1)), np.float32)


def centred(size: int) -> npt.NDArray[np.intp]:
    """`THUMB` indices spread over `size` (< `THUMB`) pixels, symmetric about the centre (the second half the
    first's mirror)."""
    half = (np.arange(THUMB // 2) * size) // THUMB
    return np.asarray(np.concatenate([half, size - 1 - half[::-1]]), dtype=np.intp)


def edges(grays: Gray) -> Gray:
    """Pictures (..., H, W) -> their edges over the interior (..., H-2, W-2): at each pixel |luma difference|
    between its neighbours above and below plus left and right; turned 180° with the picture."""
    vertical = np.abs(grays[..., 2:, 1:-1] - grays[..., :-2, 1:-1])
    return np.asarray(vertical + np.abs(grays[..., 1:-1, 2:] - grays[..., 1:-1, :-2]), dtype=np.float32)


class MeanViews:
    """An episode's sampled frames summed as the three `VIEWS`, a chunk at a time (`add`), at full size (a
    thumbnail of the sum is the sum of the thumbnails: one thumbnail per size, not per frame)."""

    def __init__(self) -> None:
        self.thumbs = np.zeros((len(VIEWS), THUMB, THUMB), dtype=np.float64)
        self.sums: Array | None = None  # (VIEWS, H, W): the frames of the current size, summed
        self.counts = np.zeros(len(VIEWS), dtype=np.int64)

    def add(self, grays: Gray, changes: Gray) -> None:
        """`grays` (n, H, W) sampled frames and `changes` (m, H, W) their |luma change| since the previous sample
        (one fewer for the episode's first chunk); edges 0 on the border."""
        if self.sums is not None and self.sums.shape[1:] != grays.shape[1:]:
            self.flush()
        if self.sums is None:
            self.sums = np.zeros((len(VIEWS), *grays.shape[1:]), dtype=np.float64)
        self.sums[0] += grays.sum(axis=0, dtype=np.float64)
        if grays.shape[1] >= 3 and grays.shape[2] >= 3:
            self.sums[1, 1:-1, 1:-1] += edges(grays).sum(axis=0, dtype=np.float64)
        self.sums[2] += changes.sum(axis=0, dtype=np.float64)
        self.counts += (len(grays), len(grays), len(changes))

    def flush(self) -> None:
        if self.sums is not None:
            self.thumbs += thumbnail(self.sums.astype(np.float32))
            self.sums = None

    def mean(self) -> Gray | None:
        """(`VIEWS`, THUMB, THUMB): each view's mean picture (zeros for motion with one sample); None without
        samples."""
        self.flush()
        if not self.counts[0]:
            return None
        return np.asarray(self.thumbs / np.maximum(self.counts, 1)[:, None, None], dtype=np.float32)


def standard(x: Gray) -> Array:
    v = x.astype(np.float64).ravel()
    v -= v.mean()
    norm = float(np.linalg.norm(v))
    return v / norm if norm > 0 else v


def flipped(thumbs: dict[int, Gray], camera: str, lengths: dict[int, int], margin: float) -> dict[int, list[Finding]]:
    """`camera_flipped`: per episode (`thumbs`: its `MeanViews.mean` of `camera`, or one THUMB x THUMB picture),
    in each view the correlation with the other episodes' median picture turned 180° minus as it is; flagged
    when above `margin` in a view where turned it correlates at least `MATCH` (`MOTION_MATCH` for motion); the
    largest such gain, over the whole episode."""
    if len(thumbs) < MIN_EPISODES:
        return {}
    order = sorted(thumbs)
    stack = np.stack([np.reshape(thumbs[e], (-1, THUMB, THUMB)) for e in order])  # (episodes, views, side, side)
    whole = np.median(stack, axis=0)
    out: dict[int, list[Finding]] = {}
    for k, e in enumerate(order):
        refs = np.median(np.delete(stack, k, axis=0), axis=0) if len(order) <= LOO_MAX else whole
        best: tuple[float, str] | None = None
        for v, (mine, ref) in enumerate(zip(stack[k], refs, strict=True)):
            unit = standard(ref)
            turned = float(standard(mine[::-1, ::-1]) @ unit)
            gain = turned - float(standard(mine) @ unit)
            if gain > margin and turned >= (MOTION_MATCH if VIEWS[v] == "motion" else MATCH):
                best = max(best or (gain, VIEWS[v]), (gain, VIEWS[v]))
        if best is not None:
            detail = f"its {best[1]} matches the other episodes' turned 180°"
            out[e] = [Finding("camera_flipped", camera, 0, lengths.get(e, 1) - 1, best[0], margin, detail=detail)]
    return out
