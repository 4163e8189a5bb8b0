"""Render report tables as JSON, CSV or Markdown (the terminal table is drawn by the command line:
openral_data/cli/stats.py)."""

from __future__ import annotations

import csv
import io
import json
import math
from collections.abc import Sequence
from typing import Any

from openral_data.metrics.report import Table, clean
from openral_data.text import printable

DATA_FORMATS = ("json", "csv", "markdown")  # what `render` writes
FORMATS = ("table", *DATA_FORMATS)  # `stats --format`


def cell(value: Any) -> str:
    """A value as one line of text: `-` for none, `yes`/`no`, 4 significant digits, controls escaped."""
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
    return printable(str(value))


def json_payload(tables: Sequence[Table]) -> dict[str, list[dict[str, Any]]]:
    """`{table name: [row as {column: value}]}`: what `stats --format json` prints (after `command`, `version`)."""
    return {t.name: [{k: clean(v) for k, v in r.items()} for r in t.records()] for t in tables}


def render(tables: Sequence[Table], fmt: str) -> str:
    if fmt == "json":  # one line, as every `--json` document (the CLI adds `command` and `version`)
        return json.dumps(json_payload(tables), default=str)
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
    raise ValueError(f"unknown format {fmt}")
