"""Feature statistics in lerobot's layout: min, max, mean, std, count, q01, q10, q50, q90, q99.

Numeric features: exact per-episode statistics; the dataset level merges them the way lerobot does
(element-wise min/max, count-weighted mean, parallel variance, count-weighted quantiles).
Images: per-channel 256-bin histograms of every frame (spatially strided to <= 64 px a side), so episode and
dataset statistics — quantiles included — are exact for the sampled pixels, in [0, 1] with shape (3, 1, 1).
"""

from __future__ import annotations

import functools
from collections.abc import Iterable, Mapping
from typing import Any, Self

import numpy as np
import numpy.typing as npt

QUANTILES = {"q01": 0.01, "q10": 0.10, "q50": 0.50, "q90": 0.90, "q99": 0.99}
STAT_KEYS = ("min", "max", "mean", "std", "count", *QUANTILES)
Stats = dict[str, npt.NDArray[Any]]
IMAGE_SIDE = 64


def numeric_stats(values: npt.NDArray[Any]) -> Stats:
    """Statistics over axis 0 of an (n, d) array (n >= 1)."""
    x = values.astype(np.float64).reshape(len(values), -1)
    out: Stats = {
        "min": x.min(axis=0),
        "max": x.max(axis=0),
        "mean": x.mean(axis=0),
        "std": x.std(axis=0),
        "count": np.array([len(x)], dtype=np.int64),
    }
    qs = np.quantile(x, list(QUANTILES.values()), axis=0)
    for i, key in enumerate(QUANTILES):
        out[key] = qs[i]
    return out


def merge_numeric(a: Stats | None, b: Stats) -> Stats:
    if a is None:
        return {k: v.copy() for k, v in b.items()}
    na, nb = float(a["count"][0]), float(b["count"][0])
    n = na + nb
    mean = (a["mean"] * na + b["mean"] * nb) / n
    var = (na * (a["std"] ** 2 + (a["mean"] - mean) ** 2) + nb * (b["std"] ** 2 + (b["mean"] - mean) ** 2)) / n
    out: Stats = {
        "min": np.minimum(a["min"], b["min"]),
        "max": np.maximum(a["max"], b["max"]),
        "mean": mean,
        "std": np.sqrt(np.maximum(var, 0.0)),
        "count": np.array([int(n)], dtype=np.int64),
    }
    for key in QUANTILES:
        out[key] = (a[key] * na + b[key] * nb) / n
    return out


LANES = 4  # `ImageStatsAccumulator.add` counts into this many interleaved copies of the histogram, summed after


@functools.lru_cache(maxsize=32)
def _sampled(height: int, width: int, channels: int) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]:
    """Where `ImageStatsAccumulator.add` reads an HWC frame of this shape: the flat indices of its sampled pixels'
    first three channels, channel after channel (every `step`-th row and column, `step` keeping <= IMAGE_SIDE a
    side), and each one's bin offset (bin = lane * 768 + channel * 256 + level; the lane cycles 0..LANES-1 from
    one sampled pixel to the next)."""
    step = max(1, -(-max(height, width) // IMAGE_SIDE))
    rows, cols = np.arange(0, height, step), np.arange(0, width, step)
    pixels = (rows[:, None] * (width * channels) + cols[None, :] * channels).ravel()
    index = np.concatenate([pixels + c for c in range(3)]).astype(np.intp)
    offsets = np.repeat(np.arange(3, dtype=np.intp) * 256, len(pixels)) + (np.arange(len(index)) % LANES) * 768
    return index, offsets.astype(np.intp)


class ImageStatsAccumulator:
    """Per-channel histograms of uint8 HWC frames."""

    def __init__(self) -> None:
        self.hist = np.zeros((3, 256), dtype=np.int64)
        self.frames = 0

    def add(self, frame: npt.NDArray[np.uint8]) -> None:
        # one gather of the sampled pixels (half the cost of a strided slice of 3-byte pixels), one bincount into
        # LANES interleaved histograms: neighbouring pixels of one level (a flat wall, table or sky) then
        # increment different counters instead of waiting on one (~30 % cheaper on such frames, the same counts)
        index, offsets = _sampled(*frame.shape[:3])
        counts = np.bincount(offsets + np.take(frame, index), minlength=LANES * 768)
        self.hist += counts.reshape(LANES, 3, 256).sum(axis=0)
        self.frames += 1

    def merge(self, other: ImageStatsAccumulator) -> None:
        self.hist += other.hist
        self.frames += other.frames

    def to_json(self) -> dict[str, Any]:
        """The histograms as `.openral/image_hist.json` keeps them for one camera (`from_json` reads them back)."""
        return {"hist": self.hist.tolist(), "frames": self.frames}

    @classmethod
    def from_json(cls, saved: dict[str, Any]) -> Self:
        acc = cls()
        acc.hist = np.asarray(saved["hist"], dtype=np.int64).reshape(3, 256)
        acc.frames = int(saved["frames"])
        return acc

    def stats(self) -> Stats:
        levels = np.arange(256, dtype=np.float64) / 255.0
        total = self.hist.sum(axis=1).astype(np.float64)
        if total.min() <= 0:
            raise ValueError("no pixels accumulated")
        mean = (self.hist * levels).sum(axis=1) / total
        var = (self.hist * (levels[None, :] - mean[:, None]) ** 2).sum(axis=1) / total
        nonzero = self.hist > 0
        mins = np.array([levels[np.argmax(row)] for row in nonzero])
        maxs = np.array([levels[255 - np.argmax(row[::-1])] for row in nonzero])
        cdf = np.cumsum(self.hist, axis=1) / total[:, None]
        out: Stats = {
            "min": mins,
            "max": maxs,
            "mean": mean,
            "std": np.sqrt(var),
            "count": np.array([self.frames], dtype=np.int64),
        }
        for key, q in QUANTILES.items():
            # lowest level whose cumulative share reaches q (the "inverted CDF" quantile)
            out[key] = np.array([levels[min(255, int(np.searchsorted(row, q)))] for row in cdf])
        return {k: (v if k == "count" else v.reshape(3, 1, 1)) for k, v in out.items()}


def to_jsonable(stats: Stats) -> dict[str, Any]:
    return {k: np.asarray(stats[k]).tolist() for k in STAT_KEYS}


def dataset_stats(order: Iterable[str], *parts: Mapping[str, Stats]) -> dict[str, Any]:
    """meta/stats.json's object: the statistics of each feature in `order` that one of `parts` has (the last
    part that has it wins), in lerobot's JSON layout and in `order`."""
    merged: dict[str, Stats] = {}
    for part in parts:
        merged.update(part)
    return {key: to_jsonable(merged[key]) for key in order if key in merged}
