"""Render report tables as a terminal table, JSON, CSV or Markdown."""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Sequence
from typing import Any

from rich.console import Console
from rich.table import Table as RichTable

from openral_data.metrics.report import Table, clean

FORMATS = ("table", "json", "csv", "markdown")


def cell(value: Any) -> str:
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        if not math.isfinite(value):
            return str(value)
        return f"{value:.4g}"
    if isinstance(value, list | tuple):
        return "; ".join(cell(v) for v in value)
    return str(value)


def render(tables: Sequence[Table], fmt: str) -> str:
    if fmt == "json":
        payload = {t.name: [{k: clean(v) for k, v in r.items()} for r in t.records()] for t in tables}
        return json.dumps(payload, indent=2, default=str)
    if fmt == "csv":
        blocks = []
        for t in tables:
            buf = io.StringIO()
            writer = csv.writer(buf, lineterminator="\n")
            writer.writerow(t.columns)
            writer.writerows([["" if v is None else v for v in (clean(x) for x in r)] for r in t.rows])
            blocks.append(buf.getvalue() if len(tables) == 1 else f"# {t.name}\n{buf.getvalue()}")
        return "\n".join(blocks).rstrip("\n")
    if fmt == "markdown":
        parts = []
        for t in tables:
            lines = [f"### {t.name}", ""] if len(tables) > 1 else []
            lines.append("| " + " | ".join(t.columns) + " |")
            lines.append("|" + "---|" * len(t.columns))
            lines += ["| " + " | ".join(cell(v).replace("|", "\\|") for v in r) + " |" for r in t.rows]
            if not t.rows:
                lines.append("| " + " | ".join(["(none)"] + ["" for _ in t.columns[1:]]) + " |")
            parts.append("\n".join(lines))
        return "\n\n".join(parts)
    if fmt == "table":
        console = Console(file=io.StringIO(), width=200, force_terminal=False, color_system=None)
        for t in tables:
            rich = RichTable(title=t.name, title_justify="left")
            for c in t.columns:
                rich.add_column(c, overflow="fold")
            for r in t.rows:
                rich.add_row(*(cell(v) for v in r))
            if not t.rows:
                rich.add_row("(none)", *("" for _ in t.columns[1:]))
            console.print(rich)
        out = console.file
        assert isinstance(out, io.StringIO)
        return out.getvalue().rstrip("\n")
    raise ValueError(f"unknown format {fmt}")
