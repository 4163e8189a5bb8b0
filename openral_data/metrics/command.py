"""The `stats` command: resolve inputs, open DuckDB views, then a query result or the full report."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import duckdb

from openral_data.errors import OutputExists, QueryError, UsageError
from openral_data.metrics import report as rep
from openral_data.metrics.render import FORMATS, render
from openral_data.metrics.sources import resolve
from openral_data.metrics.views import DEFAULT_MEMORY_LIMIT, connect


@dataclass(frozen=True)
class StatsOptions:
    paths: list[str]
    by: str | None = None
    sql: str | None = None
    fmt: str = "table"
    plot: Path | None = None
    memory_limit: str = DEFAULT_MEMORY_LIMIT
    health: bool = True


def run_stats(opts: StatsOptions) -> str:
    if opts.fmt not in FORMATS:
        raise UsageError(f"--format: {opts.fmt!r}; valid: {', '.join(FORMATS)}")
    if not opts.paths:
        raise UsageError("stats: give at least one dataset or results directory")
    by = rep.parse_by(opts.by)
    if opts.plot is not None:
        if opts.plot.suffix.lower() != ".png":
            raise UsageError(f"{opts.plot}: --plot writes a PNG; use a .png file name")
        if opts.plot.exists():
            raise OutputExists(f"{opts.plot}: --plot file exists; refusing to overwrite it")
    datasets, results = resolve(opts.paths)
    try:
        con = connect(datasets, results, opts.memory_limit)
    except duckdb.Error as exc:
        raise QueryError(f"duckdb: {_first_line(exc)}") from None
    try:
        if opts.sql is not None:
            return render([rep.run_sql(con, opts.sql)], opts.fmt)
        report = rep.build_report(con, datasets, results, by, check_health=opts.health)
        if opts.plot is not None:
            if not datasets:
                raise UsageError("--plot needs at least one dataset")
            from openral_data.metrics.plot import save_plot

            save_plot(opts.plot, report, con, datasets)
        return render(report.tables, opts.fmt)
    except duckdb.Error as exc:  # e.g. a truncated or corrupt parquet file: DuckDB's message names it
        raise QueryError(f"duckdb: {_first_line(exc)}") from None
    finally:
        con.close()


def _first_line(exc: BaseException) -> str:
    lines = [ln for ln in str(exc).splitlines() if ln.strip()]
    return lines[0] if lines else type(exc).__name__
