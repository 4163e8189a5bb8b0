"""Global flags after the command name too (`info D -v`), and `-v/-vv` a count in the help and on the line."""

from __future__ import annotations

import logging
from pathlib import Path

import pytest
import typer.main

from openral_data.cli.app import app
from openral_data.cli.globalflags import hoist
from tests.support.inproc import run_inproc
from tests.support.recorded import record_small


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return record_small(tmp_path_factory.mktemp("flags"))


def _level() -> int:
    return logging.getLogger("openral_data").level


@pytest.mark.parametrize(
    ("flags", "level"),
    [(["-v"], logging.INFO), (["-vv"], logging.DEBUG), (["-v", "-v"], logging.DEBUG), (["-q"], logging.WARNING)],
)
def test_global_flags_after_the_command(dataset: Path, flags: list[str], level: int) -> None:
    run = run_inproc("info", str(dataset), *flags)
    assert run.returncode == 0, run.stderr
    assert _level() == level
    assert "episodes" in run.stdout


def test_global_flags_after_a_subcommand_of_a_group(dataset: Path) -> None:
    run = run_inproc("stats", str(dataset), "--log-format", "json", "-v", "--format", "csv")
    assert run.returncode == 0, run.stderr
    assert _level() == logging.INFO
    run = run_inproc("info", str(dataset), "--json", "-q")
    assert run.returncode == 0 and run.stdout.count("\n") == 1


def test_verbose_and_quiet_anywhere_still_conflict(dataset: Path) -> None:
    run = run_inproc("-q", "info", str(dataset), "-v")
    assert run.returncode == 2
    assert run.stderr.startswith("error: -v/--verbose and -q/--quiet")


@pytest.mark.parametrize("args", [["-v", "2", "info", "D"], ["info", "D", "-v", "2"], ["info", "D", "--verbose", "1"]])
def test_a_number_after_v_is_refused_with_the_count_hint(args: list[str]) -> None:
    run = run_inproc(*args)
    assert run.returncode == 2
    assert run.stderr.count("\n") == 1 and "-vv DEBUG" in run.stderr


def test_help_shows_v_as_a_count_not_an_int() -> None:
    run = run_inproc("--help")
    line = next(line for line in run.stdout.splitlines() if "--verbose" in line)
    assert "<int>" not in line and "-vv" in line
    assert "[default: 0]" not in run.stdout


def test_values_and_what_follows_double_dash_stay_where_they_are() -> None:
    root = typer.main.get_command(app)
    assert hoist(root, ["stats", "D", "--sql", "-q"]) == ["stats", "D", "--sql", "-q"]
    assert hoist(root, ["info", "D", "--", "-v"]) == ["info", "D", "--", "-v"]
    assert hoist(root, ["info", "D", "--log-format", "json", "-q"]) == ["--log-format", "json", "-q", "info", "D"]
    assert hoist(root, ["--scenes-dir", "x", "info", "D"]) == ["--scenes-dir", "x", "info", "D"]
    assert hoist(root, ["stats", "report", "D", "--log-format=json"]) == ["--log-format=json", "stats", "report", "D"]
