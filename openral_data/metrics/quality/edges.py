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

from collections.abc import Callable, Iterable, Iterator, Sequence
from functools import partial
from itertools import islice

import numpy as np
import numpy.typing as npt

from openral_data.metrics.quality.findings import runs
from openral_data.metrics.quality.thresholds import Thresholds

Gray = npt.NDArray[np.float32]
Frames = Callable[[], Iterator[npt.NDArray[np.uint8]]]  # the episode's frames of one camera, all, as RGB
Luma = Callable[[npt.NDArray[np.uint8]], Gray]  # an RGB frame's luma picture (`camera.luma`)
# the episode's frames of one camera at the given indices (ascending), as RGB; fewer where the video ends first
Picked = Callable[[Sequence[int]], Iterator[npt.NDArray[np.uint8]]]
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


STILL_SCENE = 0.5  # `still_scene`: the change around a still span, against the camera's typical frame-to-frame change
# ... over this many frames before and after the span (a held picture's jump lands in the first or, the codec
# spending one frame on it, the second)
AROUND = 2


def changes(frames: Iterator[npt.NDArray[np.uint8]], luma: Luma) -> Iterator[float]:
    """Each frame's mean absolute luma difference to the previous frame (NaN for the first), frame by frame (one
    luma picture held); `luma`: `camera.luma`."""
    prev: Gray | None = None
    for rgb in frames:
        gray = luma(rgb)
        yield float("nan") if prev is None else float(np.abs(gray - prev).mean())
        prev = gray


class Full:
    """A camera's every frame in one episode, decoded again on each call (`frames`), and their change
    (`changes`), measured once per episode and camera for every check that judges it (`still_scene`, `held`,
    `onset.camera_lags`), or only at some frames (`change_at`, `picked`: those frames decoded alone; by default
    `frames` filtered)."""

    def __init__(self, frames: Frames, luma: Luma, picked: Picked | None = None) -> None:
        self.frames, self.luma = frames, luma
        self.picked: Picked = picked or partial(pick, frames)
        self.measured: Gray | None = None

    def __call__(self) -> Iterator[npt.NDArray[np.uint8]]:
        return self.frames()

    def change(self) -> Gray:
        """Every frame's change (`changes`; NaN for the first), decoded once."""
        if self.measured is None:
            self.measured = np.array(list(changes(self.frames(), self.luma)), dtype=np.float32)
        return self.measured

    def change_at(self, at: Sequence[int]) -> Gray:
        """The change (`change`'s value) at frames `at` (ascending): `change` when it has measured every frame,
        else measured from the lumas of frames `at` and of the frame before each, those alone decoded
        (`picked`). Frames not in `at`, and those past the video's end, are NaN (as the first frame is)."""
        if self.measured is not None:
            return self.measured
        need = sorted({t for f in at for t in (f - 1, f) if t >= 0})
        out = np.full(need[-1] + 1 if need else 0, np.nan, dtype=np.float32)
        wanted = set(at)
        last, prev = -2, None
        for t, rgb in zip(need, self.picked(need), strict=False):
            gray = self.luma(rgb)
            if t in wanted and last == t - 1 and prev is not None:
                out[t] = float(np.abs(gray - prev).mean())
            last, prev = t, gray
        return out

    def first_change(self, count: int) -> int | None:
        """The first frame from 1 whose picture differs from the previous one (a change of at least `REPEAT`),
        among the first `count`; None when each of them repeats the previous. Decoded only up to that frame,
        unless `change` has measured them already."""
        seen = iter(self.measured) if self.measured is not None else changes(self.frames(), self.luma)
        return next((t for t, c in enumerate(islice(seen, count)) if t and c >= REPEAT), None)


def pick(frames: Frames, wanted: Sequence[int]) -> Iterator[npt.NDArray[np.uint8]]:
    """Frames `wanted` (ascending) of all `frames`, decoded only up to the last of them."""
    keep = set(wanted)
    for t, rgb in enumerate(islice(frames(), wanted[-1] + 1 if wanted else 0)):
        if t in keep:
            yield rgb


def still_scene(change: Gray, span: Span) -> bool:
    """Whether the repeating frames `span` are a still scene rather than a held picture: the camera's change
    (`Full.change`) fades into the span and grows out of it, under `STILL_SCENE` times its typical change
    (the median over its frames that do not repeat) in each of the `AROUND` frames before and after. A held
    picture starts where the live picture was changing as usual, and when it lets go the picture jumps to where
    the scene went meanwhile; a scene nothing in view moves (an arm driven out of an overhead camera's view
    and back) goes still and comes back at the edge of its view, changing little. A span at either end of the
    episode has nothing to judge it by: held. The span is judged whole (as far as its frames repeat)."""
    a, b = span
    repeats = np.nan_to_num(change, nan=np.inf) < REPEAT
    while a > 0 and repeats[a - 1]:
        a -= 1
    while b + 1 < len(change) and repeats[b + 1]:
        b += 1
    if a - AROUND < 1 or b + AROUND >= len(change):
        return False
    live = change[np.isfinite(change) & (change >= REPEAT)]
    if not len(live):
        return False
    around = np.concatenate([change[a - AROUND : a], change[b + 1 : b + 1 + AROUND]])
    return bool(np.nanmax(around) < STILL_SCENE * float(np.median(live)))


def held(change: Gray, near: range, first: int, last: int) -> list[Span]:
    """The runs of at least two repeating frames (`change` under `REPEAT`) in window `near` that reach the
    samples' run `first`..`last`, still scenes (`still_scene`) left out."""
    part = np.nan_to_num(change[near.start : near.stop], nan=np.inf) < REPEAT
    lo = near.start
    found = [(lo + a, lo + b) for a, b in runs(part, 2) if lo + b >= first - 1 and lo + a <= last + 1]
    return [s for s in found if not still_scene(change, s)]
