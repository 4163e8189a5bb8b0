"""`stats` / `quality` tables as text that fits the terminal (docs/stats.md).

The width is the terminal's (or `$COLUMNS`; 200 when the output is piped and no width is set). A table wider
than that is printed as vertical records (`name [n]` then one `column: value` line per cell) instead of a grid
whose cells would wrap mid-word. `compact` is the default `stats` view: per group its episodes, frames, success
with its 95 % interval and median length; the comparison (rates in %, the reference named in its title) when
there are two groups to compare; health's findings, or one line saying there are none; the rest (dimensions,
sources, quality, every column) behind `--all`.
"""

from __future__ import annotations

import io
import shutil
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from rich.console import Console
from rich.measure import Measurement
from rich.table import Table as RichTable

from openral_data.cli.terminal import shown

if TYPE_CHECKING:
    from openral_data.metrics.report import Table

PIPED_WIDTH = 200  # no terminal and no $COLUMNS: a log or a pipe, read by a person later
# compact view: a table without rows is left out, except these (groups: a grid; health: a line saying so)
SHOWN_WHEN_EMPTY = ("groups", "health")
COMPACT = ("groups", "comparison", "intervention_policies", "intervention_rounds", "capture", "health")


def width() -> int:
    return shutil.get_terminal_size((PIPED_WIDTH, 24)).columns


def _percent(value: Any) -> str:
    return "-" if value is None else f"{100 * value:.1f}%"


def compact_groups(t: Table) -> Table:
    """The groups table as the default view shows it: the group's keys, episodes, frames, success, its interval."""
    from openral_data.metrics.report import Table

    keys = t.columns[: t.columns.index("episodes")]
    columns = [*keys, "episodes", "frames", "success", "95% interval", "median length"]
    rows = []
    for r in t.records():
        known = r["success_known"]
        success = f"{r['successes']}/{known} = {_percent(r['success_rate'])}" if known else "unknown"
        interval = f"{_percent(r['ci95_low'])} .. {_percent(r['ci95_high'])}" if known else "-"
        rows.append([*(r[k] for k in keys), r["episodes"], r["frames"], success, interval, r["len_median"]])
    return Table(t.name, columns, rows)


def _points(value: Any) -> str:
    return "-" if value is None else f"{100 * value:+.1f} pts"


def compact_comparison(t: Table) -> Table:
    """The comparison as the default view shows it: rates in % (as the groups table), differences in percentage
    points, the reference and its rate in the title."""
    from openral_data.metrics.report import Table

    first = t.records()[0]
    title = f"comparison with {first['reference']} (success {_percent(first['rate_ref'])}; --reference GROUP: another)"
    columns = ["group", "success", "difference", "95% interval", "p (Fisher)"]
    rows: list[list[Any]] = [
        [r["group"], _percent(r["rate"]), _points(r["diff"]), f"{_points(r['diff_low'])[:-4]} .. "
         f"{_points(r['diff_high'])}", f"{r['p_fisher']:.3g}"]
        for r in t.records()
    ]  # fmt: skip
    return Table(title, columns, rows)


def _compact(t: Table) -> Table:
    if t.name == "groups":
        return compact_groups(t)
    return compact_comparison(t) if t.name == "comparison" else t


def _grid(t: Table) -> RichTable:
    from openral_data.metrics.render import cell

    grid = RichTable(title=shown(t.name), title_justify="left")
    for c in t.columns:
        grid.add_column(shown(c), overflow="fold")
    for r in t.rows:
        grid.add_row(*(shown(cell(v)) for v in r))
    if not t.rows:
        grid.add_row("(none)", *("" for _ in t.columns[1:]))
    return grid


def _records(t: Table) -> list[str]:
    from openral_data.metrics.render import cell

    pad = max(len(c) for c in t.columns)
    lines = []
    for i, r in enumerate(t.rows):
        lines += [f"{t.name} [{i}]", *(f"  {c:<{pad}}  {cell(v)}" for c, v in zip(t.columns, r, strict=True))]
    return lines or [f"{t.name}: (none)"]


def render_tables(tables: Sequence[Table], *, compact: bool = False, columns: int | None = None) -> str:
    """The tables as text `columns` wide (default: the terminal's): each a boxed grid when it fits, else vertical
    records; every name and cell literal (a task reading `[/]` or `:x:` is shown as such)."""
    size = columns or width()
    out = io.StringIO()
    console = Console(file=out, width=size, force_terminal=False, color_system=None, emoji=False)
    hidden = [t.name for t in tables if t.name not in COMPACT]
    for t in tables:
        if compact and t.name not in COMPACT:
            continue
        if compact and not t.rows and t.name not in SHOWN_WHEN_EMPTY:
            continue
        if compact and not t.rows and t.name == "health":
            console.print(shown("health: no problems found"))
            continue
        shownt = _compact(t) if compact else t
        grid = _grid(shownt)
        natural = Measurement.get(console, console.options.update_width(10**5), grid).maximum  # unfolded
        if natural > size:
            for line in _records(shownt):
                console.print(shown(line), soft_wrap=True)
        else:
            console.print(grid)
    if compact and hidden:
        console.print(shown(f"({', '.join(hidden)} and every column: --all)"))
    return out.getvalue().rstrip("\n")
