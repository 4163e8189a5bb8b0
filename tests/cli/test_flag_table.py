"""docs/cli.md's flag table against the real CLI: each flag it marks for `record` or `replay` is an option of that
command (or, marked global, of `openral-data` itself), so the table cannot promise a flag that is not there."""

from __future__ import annotations

import re
from typing import Any

import typer.main

from openral_data.cli.app import app
from tests.support.home import REPO

DOC = REPO / "docs" / "cli.md"
COLUMNS = {1: "record", 2: "replay"}  # table column -> command


def table() -> list[tuple[list[str], bool, set[str]]]:
    """(flags, global, commands marked ✓ or named `cmd` under "where else") per row of the `<!-- flag-table -->`
    table."""
    rows, inside = [], False
    for line in DOC.read_text().splitlines():
        if line.strip() == "<!-- flag-table -->":
            inside = True
        elif inside and line.startswith("| `"):
            cells = [c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]]
            flags = [f.split()[0] for f in re.findall(r"`([^`]+)`", cells[0]) if f.startswith("-")]
            marked = {cmd for col, cmd in COLUMNS.items() if cells[col] == "✓"}
            marked |= set(re.findall(r"`([a-z]+)`", cells[3]))  # `info`, `doctor`, ...: commands
            rows.append((flags, "(global)" in cells[0], marked))
        elif inside and not line.startswith("|"):
            break
    return rows


def _options(command: Any) -> set[str]:
    return {name for p in command.params for name in (*p.opts, *p.secondary_opts)}


def test_every_flag_in_the_table_is_an_option_where_it_says() -> None:
    root: Any = typer.main.get_command(app)  # a click group (typer's own copy of click)
    rows = table()
    assert len(rows) >= 11  # the table was found and read
    missing = []
    for flags, is_global, commands in rows:
        for flag in flags:
            if is_global:
                if flag not in _options(root):
                    missing.append(f"{flag} (global)")
                continue
            for name in sorted(commands):
                if flag not in _options(root.commands[name]):
                    missing.append(f"{name} {flag}")
    assert missing == []
