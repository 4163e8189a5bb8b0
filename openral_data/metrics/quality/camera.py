"""Camera faults of one episode: every `stride`-th decoded frame measured for black, saturated, frozen (as the
previous sample) and blurred (variance of the Laplacian), one frame in memory at a time."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from openral_data.metrics.quality.thresholds import Thresholds

_LUMA = np.array([0.299, 0.587, 0.114], dtype=np.float32)


@dataclass(frozen=True)
class CameraQuality:
    samples: int
    black: float  # shares of the sampled frames
    saturated: float
    frozen: float
    blurred: float
    first_black: int | None  # frame index of the first black sample


def luma(rgb: npt.NDArray[np.uint8]) -> npt.NDArray[np.float32]:
    return np.asarray(rgb[..., :3].astype(np.float32) @ _LUMA, dtype=np.float32)


def laplacian_var(gray: npt.NDArray[np.float32]) -> float:
    """Variance of the 4-neighbour Laplacian over the interior (0.0 for a frame under 3x3)."""
    if gray.shape[0] < 3 or gray.shape[1] < 3:
        return 0.0
    lap = gray[:-2, 1:-1] + gray[2:, 1:-1] + gray[1:-1, :-2] + gray[1:-1, 2:] - 4 * gray[1:-1, 1:-1]
    return float(lap.var())


def camera_quality(frames: Iterable[npt.NDArray[np.uint8]], stride: int, th: Thresholds) -> CameraQuality:
    """The measures over frames 0, stride, 2*stride, ... of `frames` (an episode's decoded RGB frames)."""
    samples = black = saturated = frozen = blurred = 0
    first_black: int | None = None
    prev: npt.NDArray[np.float32] | None = None
    for t, rgb in enumerate(frames):
        if t % stride:
            continue
        gray = luma(rgb)
        mean = float(gray.mean())
        samples += 1
        dark, bright = mean < th.black_luma, mean > th.saturated_luma
        black += dark
        saturated += bright
        if dark and first_black is None:
            first_black = t
        if not (dark or bright):  # a black or white frame says so already; it is neither frozen nor blurred
            frozen += prev is not None and float(np.abs(gray - prev).mean()) < th.frozen_diff
            blurred += laplacian_var(gray) < th.blur_var
        prev = gray
    share = (lambda k: k / samples) if samples else (lambda k: 0.0)
    return CameraQuality(samples, share(black), share(saturated), share(frozen), share(blurred), first_black)
