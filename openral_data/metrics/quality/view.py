"""The `quality` DuckDB view (one row per episode and dataset, joinable with `episodes` on dataset and
episode_index), and the counts of flagged episodes `stats` and `info` show."""

from __future__ import annotations

import re
from collections.abc import Sequence

import duckdb
import pyarrow as pa

from openral_data.metrics.quality.cached import cached_quality, quality_of
from openral_data.metrics.quality.table import FLAGS, SCHEMA
from openral_data.metrics.report import Table
from openral_data.metrics.sources import DatasetSource

VIEW = "quality"
_MENTIONS = re.compile(r"\bquality\b", re.IGNORECASE)


def mentions_quality(sql: str | None) -> bool:
    """Whether `sql` may read the quality view (the word `quality` anywhere in it)."""
    return sql is not None and bool(_MENTIONS.search(sql))


def register_quality(con: duckdb.DuckDBPyConnection, datasets: Sequence[DatasetSource], compute: bool) -> None:
    """Create the view: each dataset's cached table; `compute`: compute (and cache) what is missing or stale,
    else a dataset without a current table has no rows there. The rows are in memory (a row per episode), so
    the view reads no file and needs no room in `lock_down`'s allowed paths."""
    parts = []
    for ds in datasets:
        table = quality_of(ds).table if compute else cached_quality(ds)
        if table is not None:
            parts.append(table.add_column(0, "dataset", pa.array([ds.label] * table.num_rows, pa.string())))
    empty = pa.schema([("dataset", pa.string()), *SCHEMA]).empty_table()
    rows = pa.concat_tables(parts) if parts else empty
    con.register("openral_quality_rows", rows.replace_schema_metadata(None))
    con.execute(f"CREATE VIEW {VIEW} AS SELECT * FROM openral_quality_rows")


def flag_counts(ds: DatasetSource) -> dict[str, int] | None:
    """Flagged episodes of `ds` per flag, plus `flagged` (any) and `episodes`; None when no current table."""
    table = cached_quality(ds)
    if table is None:
        return None
    counts = {f: sum(bool(v) for v in table.column(f).to_pylist()) for f in (*FLAGS, "flagged")}
    return {"episodes": table.num_rows, **counts}


def counts_table(datasets: Sequence[DatasetSource]) -> Table:
    """The report's `quality` table: per dataset, how many episodes raise each flag; NULL counts (and
    `computed` false) where no current table is cached (`openral-data quality` computes it)."""
    columns = ["dataset", "computed", "episodes", "flagged", *FLAGS]
    table = Table("quality", columns)
    for ds in datasets:
        counts = flag_counts(ds)
        if counts is None:
            table.rows.append([ds.label, False, *(None for _ in columns[2:])])
        else:
            table.rows.append([ds.label, True, *(counts[c] for c in columns[2:])])
    return table
