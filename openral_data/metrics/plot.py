"""`stats --plot`: one PNG with success rates and 95 % Wilson intervals per group and per-dimension action
histograms (counts computed by DuckDB; matplotlib only draws)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import duckdb

from openral_data.errors import OutputExists, UsageError
from openral_data.formats.lerobot_v3.features import ACTION
from openral_data.metrics.report import GROUP_NUMBERS, Report
from openral_data.metrics.sources import DatasetSource
from openral_data.metrics.views import files_sql, query

BINS = 40


def action_histograms(con: duckdb.DuckDBPyConnection, ds: DatasetSource) -> list[tuple[str, float, float, list[int]]]:
    """(name, low, high, counts of BINS equal bins) per action dimension, NaN/Inf left out."""
    names = ds.dim_names(ACTION)
    if not ds.data_files or ACTION not in ds.data_columns or not names:
        return []
    src = f"read_parquet({files_sql(ds.data_files)})"
    dims = len(names)
    sql = f"""
        WITH v AS (
            SELECT d, action[d] AS x FROM (SELECT action FROM {src}), range(1, {dims + 1}) r(d)
            WHERE isfinite(action[d])
        ), b AS (SELECT d, min(x) AS lo, max(x) AS hi FROM v GROUP BY d)
        SELECT d, lo, hi, least({BINS - 1}, floor((x - lo) / greatest(hi - lo, 1e-12) * {BINS}))::INT AS bin,
               count(*) AS n
        FROM v JOIN b USING (d) GROUP BY ALL ORDER BY d, bin
    """
    hist: dict[int, tuple[float, float, list[int]]] = {}
    for d, lo, hi, b, n in query(con, sql)[1]:
        entry = hist.setdefault(int(d), (float(lo), float(hi), [0] * BINS))
        entry[2][int(b)] += int(n)
    return [(names[d - 1], *hist[d]) for d in sorted(hist)]


def check_plot_path(path: Path) -> None:
    """`--plot` writes a new PNG: refuse another suffix or an existing file before any work is done."""
    if path.suffix.lower() != ".png":
        raise UsageError(f"{path}: --plot writes a PNG; use a .png file name")
    if path.exists():
        raise OutputExists(f"{path}: --plot file exists; refusing to overwrite it")


def save_plot(path: Path, report: Report, con: duckdb.DuckDBPyConnection, datasets: Sequence[DatasetSource]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups = report.table("groups")
    recs = [r for r in groups.records() if r["success_known"]]
    keys = [c for c in groups.columns if c not in GROUP_NUMBERS]
    hists = [(ds.label, h) for ds in datasets for h in action_histograms(con, ds)]
    ncols = 4
    hist_rows = math.ceil(len(hists) / ncols)
    fig = plt.figure(figsize=(4 * ncols, 3.2 * (1 + hist_rows)), layout="constrained")
    grid = fig.add_gridspec(1 + hist_rows, ncols)
    ax = fig.add_subplot(grid[0, :])
    if recs:
        labels = ["/".join(str(r[k]) for k in keys) for r in recs]
        rates = [r["success_rate"] for r in recs]
        lows = [r["success_rate"] - r["ci95_low"] for r in recs]
        highs = [r["ci95_high"] - r["success_rate"] for r in recs]
        xs = range(len(recs))
        ax.bar(xs, rates, width=0.6, color="#4c72b0", alpha=0.8)
        ax.set_xlim(-0.75, max(len(recs), 3) - 0.25)
        ax.errorbar(xs, rates, yerr=[lows, highs], fmt="none", ecolor="black", capsize=5)
        ax.set_xticks(
            list(xs), [f"{lab}\n{r['successes']}/{r['success_known']}" for lab, r in zip(labels, recs, strict=True)]
        )
    else:
        ax.text(0.5, 0.5, "no success information", ha="center", va="center", transform=ax.transAxes)
    ax.set_ylim(0, 1)
    ax.set_ylabel("success rate (95 % Wilson CI)")
    ax.set_title("success rate per " + ", ".join(keys))
    for i, (label, (name, lo, hi, counts)) in enumerate(hists):
        hax = fig.add_subplot(grid[1 + i // ncols, i % ncols])
        width = (hi - lo) / BINS if hi > lo else 1.0
        hax.bar([lo + (b + 0.5) * width for b in range(BINS)], counts, width=width, color="#dd8452")
        hax.set_title(f"{label}: action {name}", fontsize=9)
    fig.savefig(path, dpi=100)
    plt.close(fig)
