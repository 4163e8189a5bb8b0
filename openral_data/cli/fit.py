"""A rich table made to fit the terminal: the widest cells (never the first column's, the ids, nor a column named
in `whole`) cut with `…` until the table is at most the width given, each cut column keeping at least `MIN_CELL`
characters; `list` prints a note under a table so cut (--json and a wider terminal show every cell whole)."""

from __future__ import annotations

from rich.console import Console
from rich.measure import Measurement
from rich.table import Table
from rich.text import Text

MIN_CELL = 8  # a cut column keeps this many characters (its header's, when longer)


def natural_width(console: Console, table: Table) -> int:
    """The width `table` takes with nothing wrapped or cut."""
    return Measurement.get(console, console.options.update_width(10**5), table).maximum


def _widths(table: Table) -> list[int]:
    """Each column's widest cell (markup read as such) or header."""
    return [
        max([Text.from_markup(str(c.header)).cell_len, *(Text.from_markup(str(v)).cell_len for v in c.cells)])
        for c in table.columns
    ]


def cut_to_fit(console: Console, table: Table, width: int, whole: tuple[str, ...] = ()) -> bool | None:
    """Cut `table`'s widest cells so it is at most `width` wide: False when it fits whole (nothing cut), True when
    cells were cut, None when it cannot fit even so (the table is then left as it was)."""
    over = natural_width(console, table) - width
    if over <= 0:
        return False
    widths = _widths(table)
    floor = [max(MIN_CELL, Text.from_markup(str(c.header)).cell_len) for c in table.columns]
    cut = list(widths)
    while over > 0:
        shrinkable = [i for i in range(1, len(cut)) if cut[i] > floor[i] and table.columns[i].header not in whole]
        if not shrinkable:
            return None
        widest = max(shrinkable, key=lambda i: cut[i])
        cut[widest] -= 1
        over -= 1
    for column, was, now in zip(table.columns, widths, cut, strict=True):
        if now < was:
            column.max_width, column.no_wrap, column.overflow = now, True, "ellipsis"
    return True
