"""Camera faults of one episode: every `stride`-th decoded frame measured for black, saturated, frozen (as the
previous sample) and blurred (variance of the Laplacian), one frame in memory at a time."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from openral_data.metrics.quality.findings import Finding, runs, span_findings
from openral_data.metrics.quality.thresholds import Thresholds

MEASURES = ("black", "saturated", "frozen", "blurred")

_LUMA = np.array([0.299, 0.587, 0.114], dtype=np.float32)


@dataclass(frozen=True)
class Sample:
    """One measured frame: its mean luma (0-255), mean absolute luma change since the previous sample (None for
    the first), variance of its Laplacian, standard deviation of its luma (`contrast`), and the faults these
    make."""

    frame_index: int
    luma: float
    change: float | None
    sharpness: float
    contrast: float
    black: bool
    saturated: bool
    frozen: bool
    blurred: bool


@dataclass(frozen=True)
class CameraQuality:
    samples: list[Sample]

    def share(self, fault: str) -> float:
        """The share of the samples with `fault` (black, saturated, frozen, blurred); 0.0 without samples."""
        return sum(getattr(s, fault) for s in self.samples) / len(self.samples) if self.samples else 0.0

    def first(self, fault: str) -> int | None:
        return next((s.frame_index for s in self.samples if getattr(s, fault)), None)

    def findings(self, camera: str, th: Thresholds, stride: int, length: int) -> list[Finding]:
        """`camera_<fault>` findings, one per run of consecutive faulty samples, when the fault's share reaches
        `camera_flag`: from half a stride before its first sample to half a stride after its last (the fault
        began and ended somewhere between two samples: off by at most stride // 2), within the episode's
        `length` frames."""
        out: list[Finding] = []
        half = stride // 2
        for fault in MEASURES:
            share = self.share(fault)
            if share < th.camera_flag:
                continue
            mask = np.array([getattr(s, fault) for s in self.samples], dtype=bool)
            spans = [
                (max(0, self.samples[a].frame_index - half), min(length - 1, self.samples[b].frame_index + half))
                for a, b in runs(mask)
            ]
            out += span_findings(f"camera_{fault}", camera, spans, share, th.camera_flag, detail="share of samples")
        return out


def luma(rgb: npt.NDArray[np.uint8]) -> npt.NDArray[np.float32]:
    return np.asarray(rgb[..., :3].astype(np.float32) @ _LUMA, dtype=np.float32)


def laplacian_var(gray: npt.NDArray[np.float32]) -> float:
    """Variance of the 4-neighbour Laplacian over the interior (0.0 for a frame under 3x3)."""
    if gray.shape[0] < 3 or gray.shape[1] < 3:
        return 0.0
    lap = gray[:-2, 1:-1] + gray[2:, 1:-1] + gray[1:-1, :-2] + gray[1:-1, 2:] - 4 * gray[1:-1, 1:-1]
    return float(lap.var())


def camera_quality(samples_in: Iterable[npt.NDArray[np.uint8]], stride: int, th: Thresholds) -> CameraQuality:
    """The measures of an episode's sampled RGB frames, frames 0, stride, 2*stride, ... (`samples_in` holds only
        those). A black or saturated frame says so already: it is neither frozen nor blurred; nor is a flat one (its
    luma's standard deviation under `flat_std`: a solid colour, a blank wall), which neither could show."""
    samples: list[Sample] = []
    prev: npt.NDArray[np.float32] | None = None
    for k, rgb in enumerate(samples_in):
        t = k * stride
        gray = luma(rgb)
        mean, sharpness, contrast = float(gray.mean()), laplacian_var(gray), float(gray.std())
        change = None if prev is None else float(np.abs(gray - prev).mean())
        dark, bright = mean < th.black_luma, mean > th.saturated_luma
        seen = not (dark or bright) and contrast >= th.flat_std  # a picture with something in it to judge
        frozen = seen and change is not None and change < th.frozen_diff
        blurred = seen and sharpness < th.blur_var
        samples.append(Sample(t, mean, change, sharpness, contrast, dark, bright, frozen, blurred))
        prev = gray
    return CameraQuality(samples)


def stalled(cameras: dict[str, CameraQuality], th: Thresholds, stride: int, length: int) -> list[Finding]:
    """`camera_stalled`: a camera whose picture holds still over 2 or more consecutive samples while another
    camera's changes at those samples (one stream stuck while the scene moves), however short the span; placed
    like `CameraQuality.findings`."""
    out: list[Finding] = []
    half = stride // 2
    for key, q in cameras.items():
        others = [o for k, o in cameras.items() if k != key and len(o.samples) == len(q.samples)]
        if not others or not q.samples:
            continue
        changes = [[o.samples[i].change for o in others] for i in range(len(q.samples))]
        moving = np.array([any(c is not None and c >= th.frozen_diff for c in cs) for cs in changes], dtype=bool)
        mask = np.array([s.frozen for s in q.samples], dtype=bool) & moving
        spans = [
            (max(0, q.samples[a].frame_index - half), min(length - 1, q.samples[b].frame_index + half))
            for a, b in runs(mask, 2)
        ]
        share = float(mask.mean())
        out += span_findings("camera_stalled", key, spans, share, th.frozen_diff, detail="still while others move")
    return out
