"""The `--where` predicate of `episodes filter` and `browse`, evaluated once, one way: over the `episodes` view of
`views.connect` plus every `openral.*` column of the dataset's episodes metadata not already there, and the
`quality` table as `quality.<column>` when the predicate names it (`quality.mentions_quality`), on a connection
locked down to the dataset's own files and its quality cache (`views.lock_down`: no other file, no network, no
extension)."""

from __future__ import annotations

import re
from typing import Any

import duckdb

from openral_data.errors import QueryError, UsageError
from openral_data.metrics.quality import mentions_quality, register_quality
from openral_data.metrics.sources import DatasetSource
from openral_data.metrics.views import connect, files_sql, ident, lock_down, view_files

WHERE_VIEW = "openral_filter_episodes"


def where_connection(ds: DatasetSource, compute_quality: bool = False) -> duckdb.DuckDBPyConnection:
    """A locked-down connection with view `WHERE_VIEW`: the `episodes` view's columns plus `ds`'s `openral.*`
    episode columns (quote them: `"openral.success"`), and the `quality` view: `ds`'s cached quality table, which
    `compute_quality` computes (and caches) when it is missing or stale. The caller closes it."""
    extra = sorted(c for c in ds.episode_columns if c.startswith("openral."))
    cols = "".join(f", e.{ident(c)}" for c in extra)
    con = connect([ds])
    try:
        quality_files = register_quality(con, [ds], compute=compute_quality)
        con.execute(
            f"CREATE VIEW {WHERE_VIEW} AS SELECT v.*{cols} FROM episodes v "
            f"JOIN read_parquet({files_sql(ds.episode_files)}) e USING (episode_index)"
        )
        lock_down(con, [*view_files([ds]), *quality_files])  # the predicate reads these files and nothing else
    except BaseException:
        con.close()
        raise
    return con


def where_query(con: duckdb.DuckDBPyConnection, select: str, where: str, tail: str = "") -> list[tuple[Any, ...]]:
    """`SELECT {select} FROM WHERE_VIEW WHERE ({where}) {tail}` on a `where_connection`: `where` must be one
    predicate; a DuckDB error is one `QueryError` line naming --where. `select`/`tail` are ours, never the user's.
    Only a predicate naming `quality` meets its columns (`quality.idle_fraction`): every other one runs as if
    there were no quality table."""
    if not where.strip():
        raise UsageError("--where: empty predicate")
    try:
        if len(con.extract_statements(f"SELECT 1 WHERE ({where})")) != 1:
            raise QueryError(f"--where: {where!r} is not one predicate")
        source = WHERE_VIEW
        if mentions_quality(where):
            source += " LEFT JOIN (SELECT * EXCLUDE (dataset) FROM quality) quality USING (episode_index)"
        return con.execute(f"SELECT {select} FROM {source} WHERE ({where}) {tail}").fetchall()
    except duckdb.BinderException as exc:
        raise QueryError(f"--where: {_unknown_column(con, str(exc))}") from None
    except duckdb.Error as exc:
        raise QueryError(f"--where: {str(exc).splitlines()[0]}") from None


def _unknown_column(con: duckdb.DuckDBPyConnection, message: str) -> str:
    """DuckDB's Binder Error for a column or table the predicate may not name, said with the columns it may name
    (and DuckDB's closest one); any other binder error as DuckDB says it."""
    first = message.splitlines()[0]
    column = re.search(r'Referenced column "([^"]*)" not found', first)
    table = re.search(r'Referenced table "([^"]*)" not found', first)
    in_quality = re.search(r'"quality" does not have a column named "([^"]*)"', first)
    if in_quality is not None:
        names = [f"quality.{r[0]}" for r in con.execute("DESCRIBE quality").fetchall() if r[0] != "dataset"]
        return f'no column "quality.{in_quality.group(1)}"; the quality columns: {", ".join(names)}'
    found = column or table
    if found is None:
        return first
    names = [_spelled(str(r[0])) for r in con.execute(f"DESCRIBE {WHERE_VIEW}").fetchall()]
    close = re.search(r'Candidate bindings: "([^"]*)"', message)
    hint = f" (did you mean {close.group(1)}?)" if close and column is not None else ""
    what = "column" if column is not None else "table"
    return f'no {what} "{found.group(1)}"{hint}; the columns: {", ".join(names)}, and quality.<column> (docs/stats.md)'


def _spelled(name: str) -> str:
    """A column as a predicate names it: quoted when it is not a plain identifier (`"openral.success"`)."""
    return name if re.fullmatch(r"[a-z_][a-z0-9_]*", name) else ident(name)
