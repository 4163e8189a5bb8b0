"""The quality views DuckDB sees, and the counts of flagged episodes `stats` and `info` show.

* `quality`: one row per episode and dataset (table.SCHEMA), joinable with `episodes` on dataset, episode_index;
* `quality_frames`: one row per frame (speeds, idle), joinable with `frames` on dataset, episode_index,
  frame_index;
* `quality_camera_frames`: one row per sampled camera frame (luma, change, sharpness and the faults);
* `quality_findings`: one row per finding (`findings.FINDING_SCHEMA`: episode_index, check, subject, start_frame,
  end_frame, value, threshold, flag, detail), what raised each flag, to the frame.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

import duckdb
import pyarrow as pa

from openral_data.errors import DatasetError
from openral_data.formats.parquetfile import read_schema
from openral_data.metrics.quality import cache
from openral_data.metrics.quality.cached import cached_quality, quality_of
from openral_data.metrics.quality.findings import FINDING_SCHEMA
from openral_data.metrics.quality.table import FLAGS, FRAME_SCHEMA, SAMPLE_SCHEMA, SCHEMA
from openral_data.metrics.quality.thresholds import DEFAULT, Thresholds
from openral_data.metrics.report import Table
from openral_data.metrics.sources import DatasetSource
from openral_data.metrics.views import lit, path_sql

VIEW = "quality"
_MENTIONS = re.compile(r"\bquality", re.IGNORECASE)


def mentions_quality(sql: str | None) -> bool:
    """Whether `sql` may read a quality view (a word starting with `quality` anywhere in it)."""
    return sql is not None and bool(_MENTIONS.search(sql))


def register_quality(con: duckdb.DuckDBPyConnection, datasets: Sequence[DatasetSource], compute: bool) -> list[Path]:
    """Create the views: each dataset's cached tables; `compute`: compute (and cache) what is missing or stale,
    else a dataset without current tables has no rows there. The episodes' rows are held in memory (a row per
    episode); the per-frame views read their cached files in place: returned, for `lock_down`."""
    parts, files = [], []
    frames: list[str] = []
    samples: list[str] = []
    found: list[str] = []
    for ds in datasets:
        table = quality_of(ds).table if compute else cached_quality(ds)
        if table is None:
            continue
        parts.append(table.add_column(0, "dataset", pa.array([ds.label] * table.num_rows, pa.string())))
        paths = cache.cache_paths(ds.root)
        key, stride = cache.fingerprint(ds.root, DEFAULT), cache.stored_stride(table)
        for path, out in ((paths.frames, frames), (paths.camera_frames, samples), (paths.findings, found)):
            if _current(path, key, stride):
                out.append(f"SELECT {lit(ds.label)} AS dataset, * FROM read_parquet({path_sql(path)})")
                files.append(path)
    rows = pa.concat_tables(parts) if parts else _empty(SCHEMA)
    con.register("openral_quality_rows", rows.replace_schema_metadata(None))
    con.execute(f"CREATE VIEW {VIEW} AS SELECT * FROM openral_quality_rows")
    for name, selects, schema in (
        ("quality_frames", frames, FRAME_SCHEMA),
        ("quality_camera_frames", samples, SAMPLE_SCHEMA),
        ("quality_findings", found, FINDING_SCHEMA),
    ):
        con.register(f"openral_{name}_empty", _empty(schema))
        body = "\nUNION ALL BY NAME\n".join(selects) if selects else f"SELECT * FROM openral_{name}_empty"
        con.execute(f"CREATE VIEW {name} AS {body}")
    return files


def _empty(schema: pa.Schema) -> pa.Table:
    return pa.schema([("dataset", pa.string()), *schema]).empty_table()


def _current(path: Path, key: str, stride: int) -> bool:
    try:
        return path.is_file() and cache.current(read_schema(path), key, stride)
    except DatasetError:
        return False


def flag_counts(ds: DatasetSource, th: Thresholds = DEFAULT) -> dict[str, int] | None:
    """Flagged episodes of `ds` per flag, plus `flagged` (any) and `episodes`; None when no current table (of
    thresholds `th`)."""
    table = cached_quality(ds, th)
    if table is None:
        return None
    counts = {f: sum(bool(v) for v in table.column(f).to_pylist()) for f in (*FLAGS, "flagged")}
    return {"episodes": table.num_rows, **counts}


def raised_text(counts: dict[str, int]) -> str:
    """`idle 1, camera_black 1`: the flags `counts` (`flag_counts`) raises, with their episode counts."""
    return ", ".join(f"{k} {v}" for k, v in counts.items() if v and k not in ("episodes", "flagged"))


def counts_table(datasets: Sequence[DatasetSource], th: Thresholds = DEFAULT) -> Table:
    """The report's `quality` table: per dataset, how many episodes raise each flag; NULL counts (and
    `computed` false) where no current table is cached (`openral-data quality` computes it)."""
    columns = ["dataset", "computed", "episodes", "flagged", *FLAGS]
    table = Table("quality", columns)
    for ds in datasets:
        counts = flag_counts(ds, th)
        if counts is None:
            table.rows.append([ds.label, False, *(None for _ in columns[2:])])
        else:
            table.rows.append([ds.label, True, *(counts[c] for c in columns[2:])])
    return table
