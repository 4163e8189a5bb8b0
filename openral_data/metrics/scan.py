"""One DuckDB scan of a dataset's state/action lists: per-dimension summaries over the finite values, and
which columns hold NaN/Inf at all (so the per-episode NaN/Inf check only looks at those).

Plain aggregates first; NaN and ±Inf propagate into min/max/avg/stddev, so a dimension whose results are all
finite has no non-finite value. Only the dimensions that do are summarised again with NaN/Inf left out.
"""

from __future__ import annotations

import math
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


def _finite(values: tuple[object, ...]) -> bool:
    return all(v is None or (isinstance(v, float | int) and math.isfinite(v)) for v in values)


def vector_scan(con: duckdb.DuckDBPyConnection, ds: DatasetSource) -> VectorScan:
    if not ds.data_files:
        return VectorScan([], [])
    src = f"read_parquet({files_sql(ds.data_files)})"
    labels: list[tuple[str, int, str, str]] = []
    for key in ds.vector_features:
        for i, name in enumerate(ds.dim_names(key)):
            labels.append((key, i, name, f"{ident(key)}[{i + 1}]"))
    exprs = [f"count({e}), min({e}), max({e}), avg({e}), stddev_pop({e})" for *_, e in labels]
    has_reward = REWARD in ds.data_columns
    if has_reward:
        exprs.append(f"avg({ident(REWARD)})")
    if not exprs:
        return VectorScan([], [])
    row = query(con, f"SELECT {', '.join(exprs)} FROM {src}")[1][0]
    stats = {j: tuple(row[5 * j : 5 * j + 5]) for j in range(len(labels))}
    bad = [j for j, s in stats.items() if not _finite(s[1:])]
    if bad:
        cols = ", ".join(f"CASE WHEN isfinite({labels[j][3]}) THEN {labels[j][3]} END AS d{j}" for j in bad)
        again = ", ".join(f"count(d{j}), min(d{j}), max(d{j}), avg(d{j}), stddev_pop(d{j})" for j in bad)
        fixed = query(con, f"SELECT {again} FROM (SELECT {cols} FROM {src})")[1][0]
        for k, j in enumerate(bad):
            stats[j] = tuple(fixed[5 * k : 5 * k + 5])
    non_finite = [labels[j][3] for j in bad]
    if has_reward and not _finite((row[-1],)):
        non_finite.append(ident(REWARD))
    dims = [
        DimStats(key, i, name, expr, int(stats[j][0]), *(None if v is None else float(v) for v in stats[j][1:]))
        for j, (key, i, name, expr) in enumerate(labels)
    ]
    return VectorScan(dims, non_finite)
