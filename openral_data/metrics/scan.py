"""One DuckDB scan of a dataset's state/action lists: per-dimension summaries over the finite values, and
which columns hold NaN/Inf at all (so the per-episode NaN/Inf check only looks at those).

Each dimension is extracted once (a projection under the aggregate) and summarised with NaN/Inf turned into
NULL, which every aggregate skips; fewer finite values than rows says the dimension may hold a NaN/Inf.
One pass over the data files, whatever the data holds.
"""

from __future__ import annotations

from dataclasses import dataclass

import duckdb

from openral_data.metrics.sources import DatasetSource
from openral_data.metrics.views import files_sql, ident, query

REWARD = "next.reward"


@dataclass(frozen=True)
class DimStats:
    feature: str
    dim: int
    name: str
    expr: str  # the SQL expression of this dimension
    count: int  # finite values
    min: float | None
    max: float | None
    mean: float | None
    std: float | None


@dataclass(frozen=True)
class VectorScan:
    dims: list[DimStats]
    non_finite: list[str]  # SQL expressions (dimensions, reward) holding at least one NaN/Inf


def dimension_labels(ds: DatasetSource) -> list[tuple[str, int, str, str]]:
    """(feature, 0-based dim, name, SQL expression) of every summarised dimension, in report order."""
    return [
        (key, i, name, f"{ident(key)}[{i + 1}]")
        for key in ds.vector_features
        for i, name in enumerate(ds.dim_names(key))
    ]


def vector_scan(con: duckdb.DuckDBPyConnection, ds: DatasetSource) -> VectorScan:
    if not ds.data_files:
        return VectorScan([], [])
    labels = dimension_labels(ds)
    has_reward = REWARD in ds.data_columns
    if not labels and not has_reward:
        return VectorScan([], [])
    cols = [f"CASE WHEN isfinite({e}) THEN {e} END AS d{j}" for j, (*_, e) in enumerate(labels)]
    aggs = ["count(*)"] + [
        f"count(d{j}), min(d{j}), max(d{j}), avg(d{j}), stddev_pop(d{j})" for j in range(len(labels))
    ]
    if has_reward:
        cols.append(f"{ident(REWARD)} AS reward")
        aggs.append("count(*) FILTER (NOT isfinite(reward))")
    src = f"read_parquet({files_sql(ds.data_files)})"
    row = query(con, f"SELECT {', '.join(aggs)} FROM (SELECT {', '.join(cols)} FROM {src})")[1][0]
    dims, non_finite = [], []
    for j, (key, i, name, expr) in enumerate(labels):
        count, *summary = row[1 + 5 * j : 6 + 5 * j]
        if count < row[0]:  # NaN/Inf (or NULL, which the NaN/Inf check then simply does not count)
            non_finite.append(expr)
        dims.append(DimStats(key, i, name, expr, int(count), *(None if v is None else float(v) for v in summary)))
    if has_reward and row[-1]:
        non_finite.append(ident(REWARD))
    return VectorScan(dims, non_finite)
