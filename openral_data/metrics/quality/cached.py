"""A dataset's quality table, computed once and reused while its data is unchanged (`cache`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pyarrow as pa

from openral_data.metrics.quality import cache
from openral_data.metrics.quality.compute import Progress, dataset_quality
from openral_data.metrics.quality.thresholds import DEFAULT, DEFAULT_STRIDE, Thresholds
from openral_data.metrics.sources import DatasetSource


@dataclass(frozen=True)
class Quality:
    table: pa.Table
    path: Path  # where it is cached
    computed: bool  # False: read from the cache


def quality_of(
    ds: DatasetSource,
    stride: int | None = None,
    th: Thresholds = DEFAULT,
    recompute: bool = False,
    progress: Progress | None = None,
) -> Quality:
    """`ds`'s quality table: the cached one when current (and at `stride`, when given), else computed (at
    `stride`, by default `DEFAULT_STRIDE`) and cached."""
    path = cache.cache_path(ds.root)
    key = cache.fingerprint(ds.root, th)
    table = None if recompute else cache.load(path, key, stride)
    if table is not None:
        return Quality(table, path, computed=False)
    stride = DEFAULT_STRIDE if stride is None else stride
    table = dataset_quality(ds, stride, th, progress)
    cache.store(path, table, key, stride)
    return Quality(table, path, computed=True)


def cached_quality(ds: DatasetSource, th: Thresholds = DEFAULT) -> pa.Table | None:
    """The cached table if current (at whatever stride it was computed), else None; never computes."""
    return cache.load(cache.cache_path(ds.root), cache.fingerprint(ds.root, th))
