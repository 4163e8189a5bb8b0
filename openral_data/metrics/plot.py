"""`stats --plot`: one PNG with success rates and 95 % Wilson intervals per group and, per action dimension, a
histogram with one series per group (the report's `--by` groups; per dataset by default). Counts are computed by
DuckDB; matplotlib only draws. A dimension that holds one value is drawn as that value on a narrow axis."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import duckdb

from openral_data.errors import OutputExists, UsageError, WriteError
from openral_data.formats.lerobot_v3.features import ACTION
from openral_data.metrics.report import GROUP_NUMBERS, Report
from openral_data.metrics.sources import DatasetSource
from openral_data.metrics.views import files_sql, ident, lit, query

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

BINS = 40
NCOLS = 4


@dataclass
class Histogram:
    """One action dimension (by name, pooled over the datasets that have it): its finite range and, per group,
    the counts in BINS equal bins over [low, high] (all in bin 0 when the dimension is constant)."""

    name: str
    low: float
    high: float
    series: dict[str, list[int]] = field(default_factory=dict)

    @property
    def constant(self) -> bool:
        return self.high == self.low

    @property
    def edges(self) -> list[float]:
        return [self.low + (self.high - self.low) * b / BINS for b in range(BINS + 1)]


def group_keys(report: Report) -> list[str]:
    """The `--by` keys the report was grouped by (its groups table's key columns)."""
    return [c for c in report.table("groups").columns if c not in GROUP_NUMBERS]


def group_label(values: Sequence[Any]) -> str:
    return "/".join(str(v) for v in values)


def group_colours(report: Report) -> dict[str, str]:
    """One colour per group (matplotlib's `C0`..`C9` cycle, in the groups table's order), the same in every panel:
    its success-rate bar and its series in each action histogram."""
    keys = group_keys(report)
    labels = [group_label([r[k] for k in keys]) for r in report.table("groups").records()]
    return {label: f"C{i % 10}" for i, label in enumerate(labels)}


def action_histograms(
    con: duckdb.DuckDBPyConnection, datasets: Sequence[DatasetSource], keys: Sequence[str]
) -> list[Histogram]:
    """Per action dimension name (first-seen order), counts per group of `keys` (columns of the `episodes`
    view, joined to each frame by its episode); NaN/Inf left out. Bins are shared by all groups of a dimension."""
    sources = [ds for ds in datasets if ds.data_files and ACTION in ds.data_columns and ds.dim_names(ACTION)]
    hists: dict[str, Histogram] = {}
    for ds in sources:  # first pass: each dimension's range over every dataset that has it
        for d, lo, hi in query(con, f"SELECT d, min(x), max(x) FROM ({_values_sql(ds)}) GROUP BY d ORDER BY d")[1]:
            name = ds.dim_names(ACTION)[int(d) - 1]
            h = hists.setdefault(name, Histogram(name, float(lo), float(hi)))
            h.low, h.high = min(h.low, float(lo)), max(h.high, float(hi))
    for ds in sources:  # second pass: counts per group and bin, on the shared bins
        names = ds.dim_names(ACTION)
        limits = ", ".join(
            f"({d}, {lit(hists[n].low)}::DOUBLE, {lit(hists[n].high)}::DOUBLE)"
            for d, n in enumerate(names, start=1)
            if n in hists
        )
        if not limits:
            continue
        cols = ", ".join(f"e.{ident(k)}" for k in keys)
        sql = f"""
            SELECT {cols}, v.d,
                   least({BINS - 1}, greatest(0, floor((v.x - l.lo) / greatest(l.hi - l.lo, 1e-300) * {BINS})))::INT,
                   count(*)
            FROM ({_values_sql(ds)}) v
            JOIN (VALUES {limits}) l(d, lo, hi) USING (d)
            JOIN (SELECT * FROM episodes WHERE dataset = {lit(ds.label)}) e USING (episode_index)
            GROUP BY ALL
        """
        for *group, d, b, n in query(con, sql)[1]:
            counts = hists[names[int(d) - 1]].series.setdefault(group_label(group), [0] * BINS)
            counts[int(b)] += int(n)
    for h in hists.values():  # groups in label order, as the success-rate bars
        h.series = dict(sorted(h.series.items()))
    return list(hists.values())


def _values_sql(ds: DatasetSource) -> str:
    """(episode_index, d, x): every finite action value of `ds`, d 1-based."""
    dims = len(ds.dim_names(ACTION))
    return (
        f"SELECT episode_index, d, action[d] AS x FROM (SELECT episode_index, action "
        f"FROM read_parquet({files_sql(ds.data_files)})), range(1, {dims + 1}) r(d) WHERE isfinite(action[d])"
    )


def check_plot_path(path: Path) -> None:
    """`--plot` writes a new PNG: refuse another suffix or an existing file before any work is done."""
    if path.suffix.lower() != ".png":
        raise UsageError(f"{path}: --plot writes a PNG; use a .png file name")
    if path.exists():
        raise OutputExists(f"{path}: --plot file exists; refusing to overwrite it")


def save_plot(path: Path, report: Report, con: duckdb.DuckDBPyConnection, datasets: Sequence[DatasetSource]) -> None:
    import matplotlib.pyplot as plt

    fig = plot_figure(report, action_histograms(con, datasets, group_keys(report)))
    try:
        path.parent.mkdir(parents=True, exist_ok=True)  # as `view --save` does
        fig.savefig(path, dpi=100)
    except OSError as exc:  # a full disk, a folder gone read-only since the check
        raise WriteError(f"{path}: --plot: {exc.strerror or exc}") from None
    finally:
        plt.close(fig)


def plot_figure(report: Report, hists: Sequence[Histogram]) -> Figure:
    """The figure `--plot` saves: success rates per group on top, then one panel per action dimension."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    hist_rows = math.ceil(len(hists) / NCOLS)
    fig = plt.figure(figsize=(4 * NCOLS, 3.2 * (1 + hist_rows)), layout="constrained")
    grid = fig.add_gridspec(1 + hist_rows, NCOLS)
    colours = group_colours(report)
    _draw_rates(fig.add_subplot(grid[0, :]), report, colours)
    for i, h in enumerate(hists):
        _draw_histogram(fig.add_subplot(grid[1 + i // NCOLS, i % NCOLS]), h, colours)
    return fig


def _draw_rates(ax: Axes, report: Report, colours: dict[str, str]) -> None:
    keys = group_keys(report)
    recs = [r for r in report.table("groups").records() if r["success_known"]]
    if recs:
        labels = [group_label([r[k] for k in keys]) for r in recs]
        rates = [r["success_rate"] for r in recs]
        lows = [r["success_rate"] - r["ci95_low"] for r in recs]
        highs = [r["ci95_high"] - r["success_rate"] for r in recs]
        xs = range(len(recs))
        ax.bar(xs, rates, width=0.6, color=[colours.get(lab, "C0") for lab in labels], alpha=0.8)
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


def _draw_histogram(ax: Axes, h: Histogram, colours: dict[str, str]) -> None:
    """One series per group: step outlines on shared bins (filled when alone); a constant dimension is one bar
    per group at its value, on an axis of ±5 % of the value (±0.05 around 0), labelled constant."""
    n = len(h.series)
    if h.constant:
        half = max(abs(h.low) * 0.05, 0.05)
        width = half / max(n, 1)
        for j, (label, counts) in enumerate(h.series.items()):
            x = h.low - half / 2 + (j + 0.5) * width
            ax.bar(x, sum(counts), width=width * 0.9, label=label, color=colours.get(label))
        ax.set_xlim(h.low - half, h.low + half)
        ax.set_xticks([h.low], [f"{h.low:g}"])
        ax.set_title(f"action {h.name}: constant {h.low:g}", fontsize=9)
    else:
        for label, counts in h.series.items():
            ax.stairs(
                counts, h.edges, label=label, fill=n == 1, alpha=0.8 if n == 1 else 1.0, linewidth=1.2,
                color=colours.get(label),
            )  # fmt: skip
        ax.set_xlim(h.low, h.high)
        ax.set_title(f"action {h.name}", fontsize=9)
    ax.set_ylabel("frames", fontsize=8)
    if n > 1:
        ax.legend(fontsize=7)
