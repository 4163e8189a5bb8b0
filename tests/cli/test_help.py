"""`--help` of every command and sub-app: boolean flags show no `<bool>` value type; other options keep theirs."""

from __future__ import annotations

import itertools
from typing import Any

import pytest
import typer
from typer.testing import CliRunner

from openral_data.cli.app import app
from tests.support.cli import run_cli


def _command_paths(group: Any, prefix: tuple[str, ...] = ()) -> list[tuple[str, ...]]:
    """Every command and group under `group` (itself included), as the words that name it on the command line."""
    paths = [prefix]
    for name, sub in getattr(group, "commands", {}).items():
        paths += _command_paths(sub, (*prefix, name))
    return paths


PATHS = _command_paths(typer.main.get_command(app))


def test_the_tree_has_every_command_and_sub_app() -> None:
    assert {("stats",), ("record",), ("episodes", "merge"), ("pipeline",)} <= set(PATHS)
    assert len(PATHS) > 12


@pytest.mark.parametrize("path", PATHS, ids=lambda p: " ".join(p) or "openral-data")
def test_help_shows_no_bool_metavar(path: tuple[str, ...]) -> None:
    result = CliRunner().invoke(app, [*path, "--help"], env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    assert "--help" in result.output and "Show this message and exit." in result.output
    assert "<bool>" not in result.output


def test_flags_are_listed_and_valued_options_keep_their_type() -> None:
    done = run_cli("stats", "--help", env={"COLUMNS": "200"})  # the real entry point
    assert done.returncode == 0, done.stderr
    rows = {line.split()[1]: line for line in done.stdout.splitlines() if line.startswith("│ --")}
    assert "--no-health" in rows["--health"] and "<" not in rows["--health"]
    assert "<" not in rows["--help"]
    assert "<str>" in rows["--by"] and "<path>" in rows["--plot"] and "<table|json|csv|markdown>" in rows["--format"]


@pytest.mark.parametrize("columns", [80, 100])
def test_the_command_list_wraps_only_full_lines(columns: int) -> None:
    """Each command's summary in `openral-data --help` is its first sentence, wrapped only where the panel is full
    (the docstrings' own line breaks would break sentences mid-way)."""
    done = run_cli("--help", env={"COLUMNS": str(columns)})
    assert done.returncode == 0, done.stderr
    panel = done.stdout[done.stdout.index("Commands") :].splitlines()[1:-1]
    rows = [line[1:-1].rstrip() for line in panel if line.startswith("│")]
    text_at = rows[0].index(rows[0].split()[1])  # where the summaries start
    room = len(panel[0]) - 2 - text_at - 1  # the summary column's width (the panel's right padding excluded)
    for line, following in itertools.pairwise(rows):
        if following[:text_at].strip():  # the next command: nothing to check
            continue
        assert len(line[text_at:]) + 1 + len(following.split()[0]) > room, (line, following)
    assert all(len(line) <= columns for line in done.stdout.splitlines())
