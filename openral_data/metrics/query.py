"""SQL over datasets and results directories from Python: what `stats --sql` answers, as a table, not text."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from openral_data.metrics.report import Table, run_sql
from openral_data.metrics.sources import resolve
from openral_data.metrics.views import DEFAULT_MEMORY_LIMIT, connect


def stats_query(paths: Sequence[str | Path], sql: str, memory_limit: str = DEFAULT_MEMORY_LIMIT) -> Table:
    """Run `sql` over the `episodes`/`frames` (and results) views of `paths` (datasets, results dirs or globs)."""
    datasets, results = resolve([str(p) for p in paths])
    con = connect(datasets, results, memory_limit)
    try:
        return run_sql(con, sql)
    finally:
        con.close()
