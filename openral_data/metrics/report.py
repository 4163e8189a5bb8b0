"""`stats`: per-dataset/per-group numbers computed by DuckDB, comparisons, results summaries, health."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import duckdb

from openral_data.errors import QueryError, UsageError
from openral_data.formats.results import Results
from openral_data.metrics import capture, health, intervals, intervention_sql
from openral_data.metrics.episode_stats import DimensionSource, summarise
from openral_data.metrics.scan import VectorScan
from openral_data.metrics.sources import DatasetSource
from openral_data.metrics.views import check_select, ident, query

BY_KEYS = ("dataset", "task", "rskill", "scene", "robot", "seed")
GROUP_NUMBERS = (
    *("episodes", "frames", "duration_s", "successes", "success_known", "success_rate", "ci95_low", "ci95_high"),
    *("len_min", "len_p25", "len_median", "len_p75", "len_max", "len_mean"),
)


@dataclass
class Table:
    name: str
    columns: list[str]
    rows: list[list[Any]] = field(default_factory=list)

    def records(self) -> list[dict[str, Any]]:
        return [dict(zip(self.columns, r, strict=True)) for r in self.rows]


@dataclass
class Report:
    tables: list[Table]

    def table(self, name: str) -> Table:
        for t in self.tables:
            if t.name == name:
                return t
        raise KeyError(name)


def parse_by(value: str | None) -> list[str]:
    if not value:
        return ["dataset"]
    keys = [k.strip() for k in value.split(",") if k.strip()]
    bad = [k for k in keys if k not in BY_KEYS]
    if bad or not keys:
        raise UsageError(f"--by: unknown key(s) {', '.join(bad) or '(none)'}; valid: {', '.join(BY_KEYS)}")
    return keys


def run_sql(con: duckdb.DuckDBPyConnection, sql: str) -> Table:
    check_select(con, sql, "--sql")
    try:
        columns, rows = query(con, sql)
    except duckdb.Error as exc:
        raise QueryError(f"--sql: {str(exc).splitlines()[0]}") from None
    return Table("sql", columns, [list(r) for r in rows])


def group_table(con: duckdb.DuckDBPyConnection, by: Sequence[str]) -> Table:
    keys = ", ".join(ident(k) for k in by)
    sql = f"""
        SELECT {keys}, count(*) AS episodes, sum(length)::BIGINT AS frames, sum(duration_s) AS duration_s,
               count(success) AS known, count(*) FILTER (success) AS successes,
               min(length) AS len_min, quantile_cont(length, 0.25) AS len_p25, median(length) AS len_median,
               quantile_cont(length, 0.75) AS len_p75, max(length) AS len_max, avg(length) AS len_mean
        FROM episodes GROUP BY ALL ORDER BY {keys}
    """
    columns, rows = query(con, sql)
    out = Table("groups", [*by, *GROUP_NUMBERS])
    for row in rows:
        rec = dict(zip(columns, row, strict=True))
        known, k = int(rec["known"]), int(rec["successes"])
        rate: float | None = k / known if known else None
        ci = intervals.wilson(k, known) if known else None
        out.rows.append(
            [
                *(rec[b] for b in by),
                rec["episodes"],
                rec["frames"],
                rec["duration_s"],
                k if known else None,
                known,
                rate,
                None if ci is None else ci.low,
                None if ci is None else ci.high,
                rec["len_min"],
                rec["len_p25"],
                rec["len_median"],
                rec["len_p75"],
                rec["len_max"],
                rec["len_mean"],
            ]
        )
    return out


def comparison_table(
    groups: Table, by: Sequence[str], reference: str | None = None, preferred: str | None = None
) -> Table:
    """Every group with known successes against the reference group: `reference` (a name as the `reference`
    column shows it, `a` or `a/task`), else `preferred` when it has known successes, else the first group;
    difference, Newcombe 95 % CI, Fisher p."""
    out = Table("comparison", ["reference", "group", "rate_ref", "rate", "diff", "diff_low", "diff_high", "p_fisher"])

    def name(r: dict[str, Any]) -> str:
        return "/".join(str(r[b]) for b in by)

    every = [name(r) for r in groups.records()]
    if reference is not None and reference not in every:
        raise UsageError(f"--reference: {reference!r} is not a group; the groups: {', '.join(every) or '(none)'}")
    recs = [r for r in groups.records() if r["success_known"]]
    if len(recs) < 2:
        return out
    ref = next((r for r in recs if name(r) == (reference or preferred)), recs[0] if reference is None else None)
    if ref is None:
        raise UsageError(f"--reference: {reference!r}: no episode's success is known, nothing to compare against")
    k1, n1 = int(ref["successes"]), int(ref["success_known"])
    for r in (r for r in recs if r is not ref):
        k2, n2 = int(r["successes"]), int(r["success_known"])
        ci = intervals.newcombe(k2, n2, k1, n1)
        out.rows.append(
            [
                name(ref),
                name(r),
                k1 / n1,
                k2 / n2,
                k2 / n2 - k1 / n1,
                ci.low,
                ci.high,
                intervals.fisher_exact(k2, n2, k1, n1),
            ]
        )
    return out


def dimension_table(scans: dict[str, VectorScan]) -> Table:
    """Per-dimension state/action/environment-state summaries over the finite values (NaN/Inf are reported by the
    health checks)."""
    out = Table("dimensions", ["dataset", "feature", "dim", "name", "count", "min", "max", "mean", "std"])
    for label, scan in scans.items():
        for d in scan.dims:
            out.rows.append([label, d.feature, d.dim, d.name, d.count, d.min, d.max, d.mean, d.std])
    return out


def sources_table(sources: Sequence[DimensionSource]) -> Table:
    """Per dataset: whether its dimension summaries were pooled from verified episode statistics or scanned,
    how they were verified, or why the scan ran."""
    out = Table("sources", ["dataset", "dimensions", "verified_by", "note"])
    out.rows = [[s.dataset, s.dimensions, s.verified_by, s.note] for s in sources]
    return out


def results_table(con: duckdb.DuckDBPyConnection) -> Table:
    sql = """
        WITH s AS (
            SELECT results, avg(action_error) AS action_error_mean,
                   quantile_cont(action_error, 0.95) AS action_error_p95,
                   max(action_error) AS action_error_max, avg(divergence) AS divergence_mean,
                   quantile_cont(divergence, 0.95) AS divergence_p95, max(divergence) AS divergence_max
            FROM result_steps GROUP BY results
        ), e AS (
            SELECT results, any_value(kind) AS kind, any_value(dataset) AS dataset, count(*) AS episodes,
                   sum(steps)::BIGINT AS steps,
                   count(success_recorded) AS recorded_known, count(*) FILTER (success_recorded) AS recorded_successes,
                   count(success_replayed) AS replayed_known, count(*) FILTER (success_replayed) AS replayed_successes,
                   count(*) FILTER (success_recorded = success_replayed) AS outcome_agree,
                   avg(divergence_final) AS divergence_final_mean
            FROM results GROUP BY results
        )
        SELECT * FROM e LEFT JOIN s USING (results) ORDER BY results
    """
    cols, rows = query(con, sql)
    out = Table("results", [*cols, "replayed_rate", "replayed_ci95_low", "replayed_ci95_high"])
    for row in rows:
        rec = dict(zip(cols, row, strict=True))
        n, k = int(rec["replayed_known"]), int(rec["replayed_successes"])
        ci = intervals.wilson(k, n) if n else None
        out.rows.append([*row, k / n if n else None, ci.low if ci else None, ci.high if ci else None])
    return out


def intervention_tables(con: duckdb.DuckDBPyConnection) -> list[Table]:
    """Per episode, per policy and per dataset (a DAgger round's intervention rate): the share of frames a person
    drove, the takeovers and their lengths (the `intervention_episodes` view)."""
    _, episodes = query(con, intervention_sql.EPISODES_SQL)
    _, policies = query(con, intervention_sql.POLICIES_SQL)
    _, rounds = query(con, intervention_sql.ROUNDS_SQL)
    return [
        Table("interventions", list(intervention_sql.EPISODE_COLUMNS), [list(r) for r in episodes]),
        Table("intervention_policies", list(intervention_sql.POLICY_COLUMNS), [list(r) for r in policies]),
        Table("intervention_rounds", list(intervention_sql.ROUND_COLUMNS), [list(r) for r in rounds]),
    ]


def health_table(
    con: duckdb.DuckDBPyConnection, datasets: Sequence[DatasetSource], scans: dict[str, VectorScan]
) -> Table:
    out = Table("health", ["dataset", "episode", "check", "detail"])
    for ds in datasets:
        issues = health.check_dataset(con, ds, scans.get(ds.label))
        out.rows += [[i.dataset, i.episode, i.check, i.detail] for i in issues]
    return out


def build_report(
    con: duckdb.DuckDBPyConnection,
    datasets: Sequence[DatasetSource],
    results: Sequence[Results],
    by: Sequence[str],
    check_health: bool = True,
    *,
    trust_episode_stats: bool = False,
    full_scan: bool = False,
    reference: str | None = None,
) -> Report:
    """The report's tables. Dimension summaries come from verified per-episode statistics when the dataset has
    them (`episode_stats.summarise`), else from one frame scan; `sources` says which, per dataset. The comparison
    is against `reference` (a group's name), by default the first dataset given when grouped by dataset alone,
    else the first group."""
    tables: list[Table] = []
    scans: dict[str, VectorScan] = {}
    sources = []
    for ds in datasets:
        scans[ds.label], source = summarise(con, ds, trust=trust_episode_stats, full_scan=full_scan)
        sources.append(source)
    if datasets:
        groups = group_table(con, by)
        first = datasets[0].label if list(by) == ["dataset"] else None  # the first dataset given
        comparison = comparison_table(groups, by, reference, first)
        tables += [groups, comparison, dimension_table(scans), sources_table(sources)]
    if any(intervention_sql.records_interventions(ds) for ds in datasets):  # only a session that has them
        tables += intervention_tables(con)
    captured = capture.capture_rows(datasets)
    if captured:  # a real-time recording: overruns, spills, frame age and encoder lag per episode and camera
        tables.append(Table("capture", list(capture.COLUMNS), captured))
    if results:
        tables.append(results_table(con))
    if datasets and check_health:
        tables.append(health_table(con, datasets, scans))
    return Report(tables)


def clean(value: Any) -> Any:
    """JSON-safe scalars: NaN/Inf become None, lists stay lists."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, list | tuple):
        return [clean(v) for v in value]
    return value
