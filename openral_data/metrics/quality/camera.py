"""Camera faults of one episode: every `stride`-th decoded frame measured for black, saturated, frozen (as the
previous sample) and blurred (variance of the Laplacian), a few frames in memory at a time (`chunks`)."""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from openral_data.metrics.quality import edges, views
from openral_data.metrics.quality.findings import Finding, runs, span_findings
from openral_data.metrics.quality.thresholds import Thresholds

MEASURES = ("black", "saturated", "frozen", "blurred")

Span = tuple[int, int]
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
    thumb: npt.NDArray[np.float32] | None = None  # the samples' mean pictures (`views.MeanViews`)

    def share(self, fault: str) -> float:
        """The share of the samples with `fault` (black, saturated, frozen, blurred); 0.0 without samples."""
        return sum(getattr(s, fault) for s in self.samples) / len(self.samples) if self.samples else 0.0

    def first(self, fault: str) -> int | None:
        return next((s.frame_index for s in self.samples if getattr(s, fault)), None)

    def findings(
        self,
        camera: str,
        th: Thresholds,
        stride: int,
        length: int,
        moving: npt.NDArray[np.bool_] | None = None,
        full: edges.Full | None = None,
    ) -> list[Finding]:
        """`camera_<fault>` findings, one per run of consecutive faulty samples (`placed`), when the fault's share
        reaches `camera_flag` or, frozen and blurred, when the run spans `camera_run_frames` frames. A sample is
        frozen only while the robot moved since the previous one (`moving`, per frame, when known: a still robot
        makes a still picture); blurred runs one sample apart are one span (a flat frame between is no sharp one).
        `full`: the camera's every frame, decoded again to place the edges of the frozen and blurred runs kept
        to the frame (`edges`), and then kept by their length to the frame; without it they are placed within half
        a stride."""
        kept: dict[str, list[Span]] = {}
        shares: dict[str, float] = {}
        for fault in MEASURES:
            mask = np.array([getattr(s, fault) for s in self.samples], dtype=bool)
            if fault == "frozen" and moving is not None:
                mask &= self.moved(moving, stride)
            shares[fault] = share = float(mask.mean()) if len(mask) else 0.0
            long = fault in edges.EDGED
            spans = placed(self.samples, runs(mask), stride, length, fault == "frozen")
            kept[fault] = [
                (a, b)
                for (a, b), span in zip(runs(mask), spans, strict=True)
                if share >= th.camera_flag or (long and span[1] - span[0] + 1 >= th.camera_run_frames)
            ]
        refined = self.refined(kept, th, stride, length, full)
        out: list[Finding] = []
        for fault in MEASURES:
            spans = (
                refined[fault]
                if fault in refined
                else placed(self.samples, kept[fault], stride, length, fault == "frozen")
            )
            if fault == "blurred":
                spans = joined(spans, stride)
            if fault in refined and shares[fault] < th.camera_flag:  # measured to the frame: long enough still?
                spans = [(a, b) for a, b in spans if b - a + 1 >= th.camera_run_frames]
            detail = "share of samples"
            out += span_findings(f"camera_{fault}", camera, spans, shares[fault], th.camera_flag, detail=detail)
        return out

    def refined(
        self, kept: dict[str, list[Span]], th: Thresholds, stride: int, length: int, full: edges.Full | None
    ) -> dict[str, list[Span]]:
        """The frozen and blurred runs of `kept` (sample positions) measured frame by frame from the camera's
        full frame rate (`full`, decoded only when there is such a run: `edges`); {} without `full`."""
        at = [s.frame_index for s in self.samples]
        todo = [
            (f, at[a], at[b], edges.window(f, at[a], at[b], stride, length)) for f in edges.EDGED for a, b in kept[f]
        ]
        if full is None or not todo:
            return {}
        faults = edges.frame_faults(full(), [w for *_, w in todo], th, (luma, laplacian_var))
        out: dict[str, list[Span]] = {f: [] for f in edges.EDGED}
        for fault, first, last, near in todo:
            out[fault] += edges.spans(faults, fault, near, first, last)
        if out["frozen"]:  # a still scene is no frozen camera (`edges.still_scene`)
            change = full.change()
            out["frozen"] = [s for s in out["frozen"] if not edges.still_scene(change, s)]
        return {f: sorted(set(v)) for f, v in out.items()}

    def moved(self, moving: npt.NDArray[np.bool_], stride: int) -> npt.NDArray[np.bool_]:
        """Per sample: whether the robot moved on any frame since the previous sample."""
        return np.array(
            [bool(moving[max(0, s.frame_index - stride + 1) : s.frame_index + 1].any()) for s in self.samples]
        )


def placed(
    samples: list[Sample], found: list[tuple[int, int]], stride: int, length: int, since_previous: bool
) -> list[tuple[int, int]]:
    """Runs of samples (`found`, sample positions) as frame spans within `length`: from about half a stride
    before the first sample to half a stride after the last (the fault began and ended between two samples: off
    by at most stride // 2). A fault measured against the previous sample (`since_previous`: frozen) began a
    stride earlier: the previous sample shows it already."""
    half = stride // 2
    lead = stride + (stride - 3) // 2 if since_previous else half
    return [(max(0, samples[a].frame_index - lead), min(length - 1, samples[b].frame_index + half)) for a, b in found]


def joined(spans: list[tuple[int, int]], stride: int) -> list[tuple[int, int]]:
    """Spans at most one sample apart joined."""
    out: list[tuple[int, int]] = []
    for a, b in spans:
        if out and a - out[-1][1] <= stride + 1:
            out[-1] = (out[-1][0], b)
        else:
            out.append((a, b))
    return out


def luma(rgb: npt.NDArray[np.uint8]) -> npt.NDArray[np.float32]:
    """The luma picture of an RGB(A) frame (H, W, C), or of frames stacked (..., H, W, C)."""
    return np.asarray(rgb[..., :3].astype(np.float32) @ _LUMA, dtype=np.float32)


def laplacian_var(gray: npt.NDArray[np.float32]) -> float:
    """Variance of the 4-neighbour Laplacian over the interior (0.0 for a frame under 3x3)."""
    return float(laplacian_vars(gray[None])[0])


def laplacian_vars(grays: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]:
    """`laplacian_var` of each picture of `grays` (K, H, W)."""
    if grays.shape[1] < 3 or grays.shape[2] < 3:
        return np.zeros(len(grays), dtype=np.float32)
    g = grays
    lap = g[:, :-2, 1:-1] + g[:, 2:, 1:-1] + g[:, 1:-1, :-2] + g[:, 1:-1, 2:] - 4 * g[:, 1:-1, 1:-1]
    return np.asarray(lap.var(axis=(1, 2)), dtype=np.float32)


CHUNK_PIXELS = 1 << 20  # sampled frames measured together, up to this many pixels (numpy's cost per call spread)


def chunks(frames: Iterable[npt.NDArray[np.uint8]]) -> Iterator[npt.NDArray[np.uint8]]:
    """`frames` stacked in order, as many of one size as `CHUNK_PIXELS` holds (at least one)."""
    held: list[npt.NDArray[np.uint8]] = []
    for rgb in frames:
        if held and (rgb.shape != held[0].shape or (len(held) + 1) * rgb.shape[0] * rgb.shape[1] > CHUNK_PIXELS):
            yield np.stack(held)
            held = []
        held.append(rgb)
    if held:
        yield np.stack(held)


def camera_quality(samples_in: Iterable[npt.NDArray[np.uint8]], stride: int, th: Thresholds) -> CameraQuality:
    """The measures of an episode's sampled RGB frames, frames 0, stride, 2*stride, ... (`samples_in` holds only
        those). A black or saturated frame says so already: it is neither frozen nor blurred; nor is a flat one (its
    luma's standard deviation under `flat_std`: a solid colour, a blank wall), which neither could show. Measured
    a few frames at a time (`chunks`), each frame's numbers as measured alone."""
    samples: list[Sample] = []
    prev: npt.NDArray[np.float32] | None = None
    pictures = views.MeanViews()
    for rgbs in chunks(samples_in):
        grays = luma(rgbs)
        means, contrasts, sharps = grays.mean(axis=(1, 2)), grays.std(axis=(1, 2)), laplacian_vars(grays)
        diffs = np.abs(grays[1:] - grays[:-1] if prev is None else grays - np.concatenate([prev[None], grays[:-1]]))
        pictures.add(grays, diffs)
        changes: list[float | None] = [*([None] if prev is None else []), *map(float, diffs.mean(axis=(1, 2)))]
        for i in range(len(grays)):
            mean, sharpness, contrast, change = float(means[i]), float(sharps[i]), float(contrasts[i]), changes[i]
            dark, bright = mean < th.black_luma, mean > th.saturated_luma
            seen = not (dark or bright) and contrast >= th.flat_std  # a picture with something in it to judge
            frozen = seen and change is not None and change < th.frozen_diff
            blurred = seen and sharpness < th.blur_var
            t = len(samples) * stride
            samples.append(Sample(t, mean, change, sharpness, contrast, dark, bright, frozen, blurred))
        prev = grays[-1]
    return CameraQuality(samples, pictures.mean())


def stalled(
    cameras: dict[str, CameraQuality],
    th: Thresholds,
    stride: int,
    length: int,
    full: dict[str, edges.Full] | None = None,
) -> list[Finding]:
    """`camera_stalled`: a camera whose picture holds still over 2 or more consecutive samples while another
    camera's changes at those samples (one stream stuck while the scene moves), however short the span; placed
    like `CameraQuality.findings`. `full`: each camera's every frame; with it, a run is measured to the frame
    (`edges.held`): the frames that repeat, a still scene (`edges.still_scene`) or a slow one whose frames do
    not repeat left out."""
    out: list[Finding] = []
    for key, q in cameras.items():
        others = [o for k, o in cameras.items() if k != key and len(o.samples) == len(q.samples)]
        if not others or not q.samples:
            continue
        changes = [[o.samples[i].change for o in others] for i in range(len(q.samples))]
        moving = np.array([any(c is not None and c >= th.frozen_diff for c in cs) for cs in changes], dtype=bool)
        mask = np.array([s.frozen for s in q.samples], dtype=bool) & moving
        spans = placed(q.samples, runs(mask, 2), stride, length, True)
        if spans and full is not None and key in full:
            change = full[key].change()
            at = [(q.samples[a].frame_index, q.samples[b].frame_index) for a, b in runs(mask, 2)]
            near = [edges.window("frozen", first, last, stride, len(change)) for first, last in at]
            spans = sorted(
                {s for (first, last), w in zip(at, near, strict=True) for s in edges.held(change, w, first, last)}
            )
        share = float(mask.mean())
        out += span_findings("camera_stalled", key, spans, share, th.frozen_diff, detail="still while others move")
    return out


def short_video(camera: str, count: int, length: int) -> Finding:
    """`video_frames`: the camera's video ends after `count` of the episode's `length` frames; the frames it
    lacks, `count` against `length`."""
    detail = f"video ends after {count} of the episode's {length} frames"
    return Finding("video_frames", camera, count, length - 1, float(count), float(length), detail=detail)
