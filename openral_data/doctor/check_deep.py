"""`doctor --deep`: decode every episode's frames of every camera and compare their per-channel mean with the
per-episode image statistics the writer stored (meta/episodes `stats/<camera>/mean`). A swapped or shifted video
range shows another episode's frames, whose mean differs; lossy coding moves a mean by a few levels at most.
A depth video (`is_depth_map`) is compared in its `depth_unit`, decoded as lerobot's loader does, within 2% of
its quantizer's range (invalid source pixels, left out of the stats, load as depth_min / depth_max; pixels at
the top code — a "too far" +inf, e.g. a simulated camera's sky — are left out of the decoded mean too)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import av
import numpy as np

from openral_data.doctor.check_video import Placement, placements
from openral_data.doctor.findings import Finding, error
from openral_data.doctor.inspect import Dataset, read_parquet
from openral_data.formats import progress
from openral_data.formats.lerobot_v3.depth import MM_PER_METRE, QMAX, DepthSettings, decode_codes
from openral_data.formats.lerobot_v3.stats import ImageStatsAccumulator
from openral_data.formats.lerobot_v3.variants import feature_info
from openral_data.paths import regular_file

TOLERANCE = 0.02  # of the [0, 1] range, ~5 of 255 levels: well above what encoding changes in a mean


def stored_means(ds: Dataset, key: str) -> dict[int, np.ndarray[Any, Any]]:
    """episode index -> the stored per-channel mean of camera `key` (episodes without one are left out)."""
    col = f"stats/{key}/mean"
    out: dict[int, np.ndarray[Any, Any]] = {}
    for path in ds.episode_files:
        t = read_parquet(path)
        if col not in t.column_names or "episode_index" not in t.column_names:
            continue
        for e, mean in zip(t["episode_index"].to_pylist(), t[col].to_pylist(), strict=True):
            if mean is not None:
                out[int(e)] = np.asarray(mean, dtype=np.float64).ravel()
    return out


def _depth(info: dict[str, Any]) -> tuple[DepthSettings, float] | None:
    """A depth feature's quantizer and the factor from metres to its `depth_unit`; None for a colour video."""
    if not (info.get("is_depth_map") or info.get("video.is_depth_map")):
        return None
    return DepthSettings.from_info(info), (1.0 if info.get("depth_unit") == "m" else MM_PER_METRE)


def decoded_depth_means(
    path: Path, eps: list[Placement], fps: int, depth: tuple[DepthSettings, float]
) -> dict[int, np.ndarray[Any, Any]]:
    """episode -> mean depth of its decoded frames, in the feature's depth_unit, over the pixels below the top
    code: those load as depth_max whether the source said "too far" (+inf, left out of the stats) or was beyond it."""
    half = 0.5 / fps
    sums: dict[int, list[float]] = {p.episode: [] for p in eps}
    settings, unit = depth
    with av.open(str(regular_file(path))) as container:
        for frame in container.decode(video=0):
            t = frame.time
            for p in eps:
                if t is not None and p.from_ts - half <= t < p.from_ts + p.length / fps - half:
                    codes = decode_codes(frame)
                    inside = codes[codes < QMAX]
                    if inside.size:
                        sums[p.episode].append(float(settings.dequantize(inside).mean()) * unit)
                    break
    return {e: np.array([np.mean(v)]) for e, v in sums.items() if v}


def decoded_means(path: Path, eps: list[Placement], fps: int) -> dict[int, np.ndarray[Any, Any]]:
    """episode -> per-channel mean of its decoded frames (sampled as the writer samples them)."""
    half = 0.5 / fps
    accs = {p.episode: ImageStatsAccumulator() for p in eps}
    with av.open(str(regular_file(path))) as container:
        for frame in container.decode(video=0):
            t = frame.time
            if t is None:
                continue
            for p in eps:
                if p.from_ts - half <= t < p.from_ts + p.length / fps - half:
                    accs[p.episode].add(np.asarray(frame.to_ndarray(format="rgb24"), dtype=np.uint8))
                    break
    return {e: acc.stats()["mean"].ravel() for e, acc in accs.items() if acc.frames}


def check_deep(ds: Dataset) -> list[Finding]:
    if ds.episodes is None:
        return []
    out: list[Finding] = []
    total = sum(len(placements(ds, key)) for key in ds.video_keys)
    done = 0
    for key in ds.video_keys:
        want = stored_means(ds, key)
        if not want:
            continue
        depth = _depth(feature_info(ds.features[key]))
        tol = TOLERANCE if depth is None else TOLERANCE * (depth[0].depth_max - depth[0].depth_min) * depth[1]
        for path, eps in sorted(placements(ds, key).items()):
            done += 1
            progress.tick(done, total)  # the CLI's progress bar, when it set one
            if not path.is_file():
                continue  # reported as video.missing
            got = decoded_means(path, eps, ds.fps) if depth is None else decoded_depth_means(path, eps, ds.fps, depth)
            bad = [
                p.episode
                for p in eps
                if p.episode in want and (p.episode not in got or np.abs(got[p.episode] - want[p.episode]).max() > tol)
            ]
            if bad:
                out.append(
                    error(
                        "video.content",
                        ds.rel(path),
                        f"decoded frames of episode(s) {bad[:5]} do not match their stored image statistics "
                        f"(mean per channel off by more than {tol:g}): the range shows other frames",
                    )
                )
    return out
