"""`episodes resample --fps N`: a dataset at a lower frame rate, written as a new dataset (or in place) through
the editing path (`ops.write_edit`: atomic, lock-aware, episodes re-indexed).

The rule: output frame j of an episode (at j / N seconds) is source frame floor(j * F / N) (F the source fps),
the source frame at or right before its time, for j while that frame exists: an episode of n frames keeps
ceil(n * N / F). When F is a multiple of N that is exactly every (F / N)-th frame, starting with the first.
Every kept frame's row is the source's (state, action, reward, task: sampled, not averaged), the episode's
terminal flags move to its new last frame (`edit.subset`). Videos are re-timed: when every kept frame of an
episode's camera is a keyframe (lerobot's default g=2 halved, say) its packets are copied, re-stamped (pixels
exact); otherwise the kept frames are decoded and encoded again at N fps with the source's encoder settings
(pixels within codec loss). `info.fps`, every
video feature's `info.video.fps` (and a legacy per-feature `fps`) become N; statistics are recomputed.
Upsampling, N <= 0 and N equal to the source's fps are refused in one line.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

from openral_data.edit.ops import EditResult, Rewrite, check_edit_output, write_edit
from openral_data.edit.source import EpisodeData, SourceDataset
from openral_data.edit.subset import Counts, FrameSubset, Progress
from openral_data.errors import UsageError


def source_frames(n: int, old: int, new: int) -> list[int]:
    """The source frames an episode of `n` frames at `old` fps keeps at `new` fps (the module's rule)."""
    return [j * old // new for j in range(-(-n * new // old))]


def _features(features: dict[str, dict[str, Any]], fps: int) -> dict[str, dict[str, Any]]:
    """info.json features with every frame rate in them (`info.video.fps`, a legacy per-feature `fps`) set to `fps`."""
    out: dict[str, dict[str, Any]] = {}
    for key, feature in features.items():
        f = dict(feature)
        if "fps" in f:
            f["fps"] = fps
        for block in ("info", "video_info"):  # a legacy `video_info` is read as `info` (variants.feature_info)
            if isinstance(f.get(block), dict) and "video.fps" in f[block]:
                f[block] = {**f[block], "video.fps": fps}
        out[key] = f
    return out


def resample(
    dataset: Path,
    fps: int,
    out: Path | None = None,
    in_place: bool = False,
    progress: Progress | None = None,
) -> tuple[EditResult, Counts]:
    """Write `dataset` at `fps` frames per second (downsampling only, by the module's rule); the result and what
    was done to its videos."""
    if fps <= 0:
        raise UsageError(f"--fps: {fps} is not a positive frame rate")
    check_edit_output(out, in_place)  # before any reading
    src = SourceDataset(dataset)
    if fps >= src.fps:
        raise UsageError(
            f"--fps: {fps} is not below {dataset}'s {src.fps} fps (resample only lowers the frame rate)"
            if fps > src.fps
            else f"--fps: {dataset} is already at {fps} fps"
        )

    def picks(ep: EpisodeData) -> list[int]:
        return source_frames(ep.length, src.fps, fps)

    subset = FrameSubset(src, picks, fps)

    rewrite = Rewrite(
        transform=subset.step(progress),
        schema=replace(src.schema, fps=fps),
        features=_features(src.features, fps),
        details={"from_fps": src.fps, "to_fps": fps, "rule": f"frame j is source frame floor(j * {src.fps} / {fps})"},
    )
    try:
        result = write_edit([(src, e) for e in range(src.total)], src.root, out, in_place, "resample", rewrite)
    finally:
        subset.close()
    return result, subset.counts
