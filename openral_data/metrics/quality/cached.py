"""A dataset's quality tables, computed once and reused while its data is unchanged (`cache`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from openral_data.formats import atomic
from openral_data.formats.write_errors import write_error
from openral_data.metrics.quality import cache
from openral_data.metrics.quality.compute import Progress, Rows, Sink, camera_pass, motion_pass
from openral_data.metrics.quality.table import FRAME_SCHEMA, SAMPLE_SCHEMA, finish
from openral_data.metrics.quality.thresholds import DEFAULT, DEFAULT_STRIDE, Thresholds, data_kind, for_kind
from openral_data.metrics.sources import DatasetSource, open_dataset


@dataclass(frozen=True)
class Quality:
    table: pa.Table  # one row per episode
    paths: cache.CachePaths  # where the tables are cached
    computed: bool  # False: read from the cache


def quality_of(
    ds: DatasetSource,
    stride: int | None = None,
    th: Thresholds = DEFAULT,
    recompute: bool = False,
    progress: Progress | None = None,
) -> Quality:
    """`ds`'s quality table: the cached one when current (and at `stride`, when given), else computed (at
    `stride`, by default `DEFAULT_STRIDE`) and cached with its per-frame tables. A `quality` of the same dataset
    computing meanwhile is waited for (`cache.computing`); then its tables are the cached ones."""
    paths = cache.cache_paths(ds.root)
    key = cache.fingerprint(ds.root, th)
    table = None if recompute else cache.load(paths.episodes, key, stride)
    if table is not None:
        return Quality(table, paths, computed=False)
    try:
        with cache.computing(paths):
            table = None if recompute else cache.load(paths.episodes, key, stride)
            if table is not None:  # computed by the one waited for
                return Quality(table, paths, computed=False)
            stride = DEFAULT_STRIDE if stride is None else stride
            return Quality(computed(ds, paths, (key, stride), th, progress), paths, computed=True)
    except OSError as exc:  # a full disk, or a cache file that is a folder: one line, the dataset untouched
        doing = f"writing the quality cache ({exc.filename2 or exc.filename})"
        raise write_error(paths.episodes.parent, exc, doing) from None


def computed(
    ds: DatasetSource, paths: cache.CachePaths, keyed: tuple[str, int], th: Thresholds, progress: Progress | None
) -> pa.Table:
    """The episodes' table of `ds`, computed at stride `keyed[1]` and cached at `paths` under key `keyed[0]`,
    with the per-frame tables and the findings."""
    key, stride = keyed
    kind = data_kind(ds.root)
    th = for_kind(th, kind)
    meta = cache.metadata(key, stride)
    rows: Rows = {}
    cameras: list[bool] = []

    def streamed(schema: pa.Schema, fill: Callable[[Sink], None]) -> Callable[[Path], None]:
        def write(tmp: Path) -> None:
            with pq.ParquetWriter(tmp, schema.with_metadata(meta), compression="snappy", write_page_checksum=True) as w:
                fill(w.write_table)

        return write

    batch = atomic.Batch()
    try:
        batch.write_with(paths.frames, streamed(FRAME_SCHEMA, lambda sink: rows.update(motion_pass(ds, th, sink))))
        batch.write_with(
            paths.camera_frames,
            streamed(SAMPLE_SCHEMA, lambda sink: cameras.append(camera_pass(ds, rows, stride, th, sink, progress))),
        )
        table, findings = finish(rows, stride, kind, th, has_cameras=cameras[0])
        table = table.replace_schema_metadata(meta)
        batch.write_with(paths.findings, atomic.parquet_writer(findings.replace_schema_metadata(meta)))
        batch.write_with(paths.episodes, atomic.parquet_writer(table))  # last: it makes the others count
        batch.commit()
    finally:
        batch.discard()
    return table


def cached_quality(ds: DatasetSource, th: Thresholds = DEFAULT) -> pa.Table | None:
    """The cached table if current (at whatever stride it was computed), else None; never computes."""
    return cache.load(cache.cache_paths(ds.root).episodes, cache.fingerprint(ds.root, th))


def quality(
    dataset: Path | str,
    stride: int | None = None,
    thresholds: Thresholds = DEFAULT,
    recompute: bool = False,
) -> Quality:
    """The Python face of `openral-data quality DATASET`: the dataset's quality table (one row per episode,
    measures and flags; `Quality.table`, a pyarrow Table), from the cache when current, else computed and cached.
    `thresholds`: `Thresholds(...)` other than the defaults (cached under their own key)."""
    return quality_of(open_dataset(Path(dataset)), stride, thresholds, recompute)
