"""Frozen and blurred camera spans measured to the frame (docs/stats.md, "Quality").

The sampled frames (every `stride`-th) find a run of frozen or blurred samples; its edges lie somewhere between
the last good sample and the first faulty one. Only for the runs that could raise a flag, the camera is decoded
again and the frames around the run are measured one by one (`frame_faults`, one frame's luma in memory at a
time): a frame *repeats* the previous one when their mean absolute luma difference is under `REPEAT` (a held
picture decodes as exact copies; a slow live scene, even one a renderer updates every other frame, does not
repeat for two frames in a row), a frame is blurred as a sample is. The span is the run of such frames that
meets the samples' run (`spans`): its edges are the frames', and a run of samples whose frames do not repeat
is no frozen span at all. A clean episode has no such run: it is decoded once.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator

import numpy as np
import numpy.typing as npt

from openral_data.metrics.quality.findings import runs
from openral_data.metrics.quality.thresholds import Thresholds

Gray = npt.NDArray[np.float32]
Frames = Callable[[], Iterator[npt.NDArray[np.uint8]]]  # the episode's frames of one camera, all, as RGB
Span = tuple[int, int]
EDGED = ("frozen", "blurred")
REPEAT = 0.1  # mean absolute luma difference (0-255) under which a frame repeats the previous one (copies: 0.0)


def window(fault: str, first: int, last: int, stride: int, length: int) -> range:
    """The frames that can belong to the span of a run of faulty samples at frames `first`..`last` (`fault` in
    `EDGED`): a frozen sample matched the previous sample, so its hold may have begun two strides before it; a
    blurred sample's blur began after the previous (sharp) sample. Both end before the next sample."""
    back = 2 * stride - 1 if fault == "frozen" else stride - 1
    return range(max(0, first - back), min(length, last + stride))


def frame_faults(
    frames: Iterator[npt.NDArray[np.uint8]],
    wanted: Iterable[range],
    th: Thresholds,
    measure: tuple[Callable[[npt.NDArray[np.uint8]], Gray], Callable[[Gray], float]],
) -> dict[int, tuple[bool, bool]]:
    """Per frame of the `wanted` windows: (it repeats the previous frame, it is blurred); `measure`: the luma
    of an RGB frame and the sharpness of a luma picture (`camera.luma`, `camera.laplacian_var`). Stops after the
    last frame wanted."""
    keep = {t for r in wanted for t in r}
    need = keep | {t - 1 for t in keep}
    luma, sharpness = measure
    out: dict[int, tuple[bool, bool]] = {}
    prev: Gray | None = None
    for t, rgb in enumerate(frames):
        if t > max(need, default=-1):
            break
        if t not in need:
            prev = None
            continue
        gray = luma(rgb)
        if t in keep:
            repeat = prev is not None and float(np.abs(gray - prev).mean()) < REPEAT
            out[t] = (repeat, sharpness(gray) < th.blur_var)
        prev = gray
    return out


def spans(faults: dict[int, tuple[bool, bool]], fault: str, near: range, first: int, last: int) -> list[Span]:
    """The runs of frames with `fault` (`frame_faults`) in window `near` that reach the samples' run
    `first`..`last`; a frozen run from its first repeating frame, at least two frames long."""
    which = 0 if fault == "frozen" else 1
    mask = np.array([faults.get(t, (False, False))[which] for t in near], dtype=bool)
    found = runs(mask, 2 if fault == "frozen" else 1)
    lo = near.start
    return [(lo + a, lo + b) for a, b in found if lo + b >= first - 1 and lo + a <= last + 1]
