"""`stats recompute`: rewrite a dataset with every feature's statistics computed again from its content.

Numeric features: from the rows, per episode and merged per dataset, as our writer does while recording (the
writer recomputes them on every copy). Cameras: from decoded pixels with the writer's method
(`ImageStatsAccumulator`: per-channel histograms of every frame, spatially strided to <= 64 px a side), a video
camera's frames decoded from its mp4 (the packets themselves are copied, never re-encoded), a `dtype: image`
camera's from its embedded PNG/JPEG. Dataset-level camera statistics come from the summed histograms, so they are
exact (quantiles included), and `.openral/image_hist.json` is written again. A segmentation mask's statistics are
its ids' (formats/lerobot_v3/masks.py), merged per dataset as numeric features are. Nothing else changes.
"""

from __future__ import annotations

import dataclasses
import io
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import av
import numpy as np
import numpy.typing as npt

from openral_data.edit.ops import EditResult, Rewrite, write_edit
from openral_data.edit.source import EpisodeData, SourceDataset
from openral_data.errors import DatasetError
from openral_data.formats.lerobot_v3.images import decode_image
from openral_data.formats.lerobot_v3.masks import decode_mask, is_mask, mask_stats
from openral_data.formats.lerobot_v3.stats import ImageStatsAccumulator, Stats


def recompute(dataset: Path, out: Path | None, in_place: bool = False) -> EditResult:
    """Write `dataset` with recomputed statistics to `out` (or in place)."""
    src = SourceDataset(dataset)
    for key in src.camera_key.values():
        src.refuse_depth(key, "stats recompute")
    images = [k for k in src.carried if src.features[k].get("dtype") == "image"]
    # a mask's statistics are its ids', merged per dataset as numbers (formats/lerobot_v3/masks.py)
    masks = [k for k in images if is_mask(src.features[k])]
    pictures = [k for k in images if k not in masks]
    video_hist = {name: ImageStatsAccumulator() for name in src.camera_names()}
    image_hist = {key: ImageStatsAccumulator() for key in pictures}

    def restated(ep: EpisodeData) -> EpisodeData:
        image_stats = {}
        for name, mp4 in ep.videos.items():
            acc = _histogram(_decoded(mp4, f"{src.root}: camera {name}: episode {ep.index}"), ep.length)
            video_hist[name].merge(acc)
            image_stats[name] = acc.stats()
        column_stats = {}
        for key in images:
            where = f"{src.root}: {key}: episode {ep.index}"
            column_stats[key], hist = column_stats_of(src.features[key], ep.columns[key].to_pylist(), where)
            if hist is not None:
                image_hist[key].merge(hist)
        return dataclasses.replace(ep, image_stats=image_stats, column_stats=column_stats)

    rewrite = Rewrite(transform=restated, image_hist=video_hist, column_hist=image_hist)
    return write_edit([(src, e) for e in range(src.total)], dataset, out, in_place, "stats recompute", rewrite)


def column_stats_of(
    feature: dict[str, Any], cells: list[object], where: str
) -> tuple[Stats, ImageStatsAccumulator | None]:
    """A carried `dtype: image` column's statistics over `cells` (one episode's), from its decoded pictures: a
    segmentation mask's ids' (no histogram), else the pixels' (with their histogram)."""
    if is_mask(feature):
        return mask_stats([decode_mask(c, f"{where}: frame {i}") for i, c in enumerate(cells)]), None
    acc = _histogram((decode_image(c, f"{where}: frame {i}") for i, c in enumerate(cells)), len(cells))
    return acc.stats(), acc


def _histogram(frames: Iterator[npt.NDArray[np.uint8]], n: int) -> ImageStatsAccumulator:
    acc = ImageStatsAccumulator()
    for frame in frames:
        acc.add(frame)
    if acc.frames != n:  # the source checks its clips' frame counts; a short image column cannot occur either
        raise DatasetError(f"{acc.frames} frames decoded, the episode has {n}", code="dataset.invalid")
    return acc


def _decoded(mp4: bytes, where: str) -> Iterator[npt.NDArray[np.uint8]]:
    """Every frame of a whole mp4 (an episode's clip), as RGB arrays."""
    try:
        with av.open(io.BytesIO(mp4), mode="r") as container:
            for frame in container.decode(container.streams.video[0]):
                yield np.asarray(frame.to_ndarray(format="rgb24"), dtype=np.uint8)
    except (av.error.FFmpegError, IndexError) as exc:
        raise DatasetError(f"{where}: cannot decode video: {type(exc).__name__}", code="dataset.invalid") from None
