"""The `stats` command: resolve inputs, open DuckDB views, then a query result or the full report."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import duckdb

from openral_data.errors import QueryError, UsageError
from openral_data.metrics import report as rep
from openral_data.metrics.plot import check_plot_path, save_plot
from openral_data.metrics.quality import counts_table, mentions_quality, register_quality
from openral_data.metrics.render import FORMATS, render
from openral_data.metrics.sources import resolve
from openral_data.metrics.views import DEFAULT_MEMORY_LIMIT, connect, lock_down, view_files


@dataclass(frozen=True)
class StatsOptions:
    paths: list[str]
    by: str | None = None
    sql: str | None = None
    fmt: str = "json"  # the command line defaults to its terminal table (cli/stats.py)
    plot: Path | None = None
    memory_limit: str = DEFAULT_MEMORY_LIMIT
    health: bool = True
    trust_episode_stats: bool = False  # use a foreign dataset's unverified per-episode stats (docs/stats.md)
    full_scan: bool = False  # summarise the frames even when verified per-episode stats could stand for them
    reference: str | None = None  # the group the others are compared with (default: the first dataset given)


def run_stats(opts: StatsOptions) -> str:
    """The tables as JSON, CSV or Markdown (`--format table` is the command line's: openral_data/cli/stats.py)."""
    if opts.fmt == "table":
        raise ValueError("run_stats: --format table is drawn by the command line (cli.stats.stats_text)")
    return render(stats_tables(opts), opts.fmt)


def stats_query(paths: Sequence[str | Path], sql: str, memory_limit: str = DEFAULT_MEMORY_LIMIT) -> rep.Table:
    """`stats --sql` from Python: `sql` over the views of `paths` (datasets, results dirs or globs), as a table."""
    return stats_tables(StatsOptions([str(p) for p in paths], sql=sql, memory_limit=memory_limit))[0]


def stats_tables(opts: StatsOptions) -> list[rep.Table]:
    """The query result (`--sql`) or the report's tables."""
    if opts.fmt not in FORMATS:
        raise UsageError(f"--format: {opts.fmt!r}; valid: {', '.join(FORMATS)}")
    if not opts.paths:
        raise UsageError("stats: give at least one dataset or results directory")
    by = rep.parse_by(opts.by)
    if opts.plot is not None:
        check_plot_path(opts.plot)
    datasets, results = resolve(opts.paths)
    try:
        con = connect(datasets, results, opts.memory_limit)
    except duckdb.Error as exc:
        raise QueryError(f"duckdb: {_first_line(exc)}") from None
    try:
        # only a query naming quality computes it; the report shows the cached counts
        quality_files = register_quality(con, datasets, compute=mentions_quality(opts.sql))
        if opts.sql is not None:  # the user's query may read the views' files, nothing else (docs/threat-model.md)
            lock_down(con, [*view_files(datasets, results), *quality_files])
            return [rep.run_sql(con, opts.sql)]
        report = rep.build_report(
            con,
            datasets,
            results,
            by,
            check_health=opts.health,
            trust_episode_stats=opts.trust_episode_stats,
            full_scan=opts.full_scan,
            reference=opts.reference,
        )
        if opts.plot is not None:
            if not datasets:
                raise UsageError("--plot needs at least one dataset")
            save_plot(opts.plot, report, con, datasets)
        return [*report.tables, counts_table(datasets)] if datasets else list(report.tables)
    except duckdb.Error as exc:  # e.g. a truncated or corrupt parquet file: DuckDB's message names it
        raise QueryError(f"duckdb: {_first_line(exc)}") from None
    finally:
        con.close()


def _first_line(exc: BaseException) -> str:
    lines = [ln for ln in str(exc).splitlines() if ln.strip()]
    return lines[0] if lines else type(exc).__name__
