"""Per-episode statistics a v2.x dataset lacks, computed the way lerobot computes them when it records.

lerobot's v2.1 -> v3.0 converter reads every episode's statistics from `meta/episodes_stats.jsonl`: a v2.0
dataset has no such file, and many v2.1 datasets have one without their cameras' statistics (lerobot issue
#3786: the converted `meta/stats.json` then lacks the camera keys training looks up). `missing_stats` lists what
an episode lacks; `episode_stats` computes it with lerobot's own `compute_episode_stats` over the episode's
frames as lerobot's writer hands them over: numeric columns as arrays (a shape-[1] feature as one value per
frame), cameras as a list of image files, of which lerobot samples (`sample_indices`) the frames it reads.
Those sampled frames are written (the image bytes of a `dtype: image` column as stored, a video's decoded
frames as PNG) under a scratch folder the caller owns. Video statistics are of the decoded frames: the
pictures lerobot saw before encoding are gone.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pyarrow as pa

from openral_data.edit.recode import clip_frames
from openral_data.errors import DatasetError
from openral_data.formats.parquetfile import read_table
from openral_data.paths import read_regular
from openral_data.upgrade.legacy import Legacy

NO_STATS = ("string", "language")  # lerobot keeps no statistics of text
CAMERAS = ("image", "video")


def missing_stats(legacy: Legacy, episode: int, stale: list[str]) -> list[str]:
    """The features of `episode` with statistics lerobot would keep but the dataset does not have (or has of
    values since rewritten: `stale`)."""
    have = (legacy.stats or {}).get(episode, {})
    return [k for k, ft in legacy.features.items() if ft["dtype"] not in NO_STATS and (k not in have or k in stale)]


def episode_stats(
    legacy: Legacy, episode: int, keys: list[str], path: Path, scratch: Path
) -> dict[str, dict[str, Any]]:
    """lerobot's `compute_episode_stats` of `keys` over episode `episode`, whose data file is `path` (OLD's or its
    rewrite, `columns.fixed_data`); JSON-ready (lists, not arrays)."""
    from lerobot.datasets.compute_stats import compute_episode_stats, sample_indices

    table = read_table(path)
    n = table.num_rows
    sampled = set(sample_indices(n))
    data: dict[str, Any] = {}
    for key in keys:
        ft = legacy.features[key]
        if ft["dtype"] == "video":
            data[key] = _video_frames(legacy.videos[key][episode], n, sampled, scratch / key)
            continue
        if key not in table.column_names:
            raise DatasetError(f"{path}: column {key!r} (a feature of info.json) is missing", code="dataset.invalid")
        if ft["dtype"] == "image":
            data[key] = _image_files(table.column(key), n, sampled, scratch / key, f"{path}: {key}")
        else:
            data[key] = _values(table.column(key), ft, n, f"{path}: {key}")
    stats = compute_episode_stats(data, {k: legacy.features[k] for k in keys})
    return {key: {name: np.asarray(v).tolist() for name, v in feature.items()} for key, feature in stats.items()}


def _values(column: pa.ChunkedArray, ft: dict[str, Any], n: int, source: str) -> npt.NDArray[Any]:
    """A numeric column as lerobot's writer stacks it: (n, *shape), a shape-[1] feature as (n,)."""
    flat: pa.Array = column.combine_chunks()
    while pa.types.is_list(flat.type) or pa.types.is_fixed_size_list(flat.type) or pa.types.is_large_list(flat.type):
        flat = flat.flatten()
    shape = [int(d) for d in ft["shape"]]
    try:
        values = np.asarray(flat.to_numpy(zero_copy_only=False))
        return values.reshape(n) if shape == [1] else values.reshape(n, *shape)
    except (ValueError, pa.ArrowException) as exc:
        raise DatasetError(
            f"{source}: values do not fit the feature's shape {shape} ({exc})", code="dataset.invalid"
        ) from None


def _image_files(column: pa.ChunkedArray, n: int, sampled: set[int], folder: Path, source: str) -> list[str]:
    """The column's pictures as files lerobot opens: the sampled frames' stored bytes written, the others named."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = [str(folder / f"frame-{t:06d}.png") for t in range(n)]
    for t in sorted(sampled):
        cell = column[t].as_py()
        data = cell.get("bytes") if isinstance(cell, dict) else None
        if not isinstance(data, bytes) or not data:
            raise DatasetError(f"{source}: frame {t}: no image bytes stored", code="dataset.invalid")
        Path(paths[t]).write_bytes(data)
    return paths


def _video_frames(video: Path, n: int, sampled: set[int], folder: Path) -> list[str]:
    """The episode's mp4 decoded: the sampled frames written as PNG files lerobot opens, the others named."""
    from PIL import Image

    folder.mkdir(parents=True, exist_ok=True)
    paths = [str(folder / f"frame-{t:06d}.png") for t in range(n)]
    count = 0
    for t, frame in enumerate(clip_frames(read_regular(video), str(video))):
        if t in sampled:
            Image.fromarray(frame).save(paths[t])
        count = t + 1
    if count < n:
        raise DatasetError(f"{video}: {count} frames decoded, the episode has {n}", code="dataset.invalid")
    return paths
