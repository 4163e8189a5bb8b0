"""The edges of a frozen or blurred camera span to the frame (docs/stats.md, "Quality").

The sampled frames (every `stride`-th) find a run of frozen or blurred samples; its edges lie somewhere between
the last good sample and the first faulty one. Only for the runs that raise a flag, the camera is decoded again
at its full frame rate, and only the frames in a window around each edge are converted (`window_lumas`): a frame
repeats the held picture (`frozen_edges`) or is blurred (`blurred_edges`) one by one, outwards from the run's
samples. A clean episode raises no such run: it is decoded once.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator

import numpy as np
import numpy.typing as npt

from openral_data.metrics.quality.thresholds import Thresholds

Gray = npt.NDArray[np.float32]
Frames = Callable[[], Iterator[npt.NDArray[np.uint8]]]  # the episode's frames of one camera, all, as RGB
Lumas = dict[int, Gray]
Span = tuple[int, int]
EDGED = ("frozen", "blurred")


def window(fault: str, first: int, last: int, stride: int, length: int) -> range:
    """The frames whose pictures place a run of faulty samples at frames `first`..`last` (`fault` in `EDGED`):
    a frozen sample matched the previous one, so its hold may have begun two strides before it; a blurred
    sample's blur began after the previous (sharp) sample. Both end before the next sample."""
    back = 2 * stride if fault == "frozen" else stride
    return range(max(0, first - back), min(length, last + stride))


def wanted(runs: Iterable[tuple[str, int, int]], stride: int, length: int) -> set[int]:
    """The frames the edges of `runs` (fault, first and last sample frame) need: near each edge only."""
    out: set[int] = set()
    for fault, first, last in runs:
        near = window(fault, first, last, stride, length)
        out.update(t for t in near if t <= first or t >= last)
    return out


def window_lumas(frames: Iterator[npt.NDArray[np.uint8]], frames_wanted: set[int], luma: Callable[..., Gray]) -> Lumas:
    """The luma of the `frames_wanted` frames (positions in the episode), the others skipped unconverted
    beyond the decoder; stops after the last one wanted."""
    out: Lumas = {}
    last = max(frames_wanted, default=-1)
    for t, rgb in enumerate(frames):
        if t > last:
            break
        if t in frames_wanted:
            out[t] = luma(rgb)
    return out


def _walk(lumas: Lumas, start: int, step: int, bound: int, same: Callable[[Gray], bool]) -> int:
    """From frame `start`, the furthest frame towards `bound` (`step` ±1) up to which every frame is `same`."""
    t = start
    while (t + step - bound) * step <= 0 and t + step in lumas and same(lumas[t + step]):
        t += step
    return t


def frozen_edges(lumas: Lumas, first: int, last: int, stride: int, length: int, th: Thresholds) -> Span:
    """The frames that repeat the held picture of a frozen run sampled at `first`..`last`: outwards from each,
    frames within `frozen_diff` (mean absolute luma) of that sample's picture; the span starts on the frame
    after the first that shows it (that one was still live: it is the picture held)."""
    if first not in lumas or last not in lumas:
        return first, last
    lo, hi = window("frozen", first, last, stride, length)[0], min(length - 1, last + stride - 1)
    head, tail = lumas[first], lumas[last]
    a = _walk(lumas, first, -1, lo, lambda g: float(np.abs(g - head).mean()) < th.frozen_diff)
    b = _walk(lumas, last, 1, hi, lambda g: float(np.abs(g - tail).mean()) < th.frozen_diff)
    return min(a + 1, first), b


def blurred_edges(
    lumas: Lumas, first: int, last: int, stride: int, length: int, th: Thresholds, sharpness: Callable[[Gray], float]
) -> Span:
    """The frames of a blurred run sampled at `first`..`last`: outwards from each, frames whose `sharpness`
    (variance of the Laplacian) stays under `blur_var`."""
    lo, hi = max(0, first - stride + 1), min(length - 1, last + stride - 1)
    a = _walk(lumas, first, -1, lo, lambda g: sharpness(g) < th.blur_var)
    b = _walk(lumas, last, 1, hi, lambda g: sharpness(g) < th.blur_var)
    return a, b
