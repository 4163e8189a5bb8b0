"""Progress on the rest of the long work (docs/cli.md): `episodes merge` and `episodes split` show the episodes
written and `push` the files sent, on a terminal's stderr; nothing with `-q`. Drawn through a forced-terminal
console, as a user sees it."""

from __future__ import annotations

import io
from pathlib import Path

import pytest
from rich.console import Console

from openral_data.cli import terminal
from tests.support.hub_endpoint import local_hub
from tests.support.inproc import run_inproc
from tests.support.recorded import record_small


@pytest.fixture(scope="module")
def datasets(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    return record_small(tmp_path_factory.mktemp("a")), record_small(tmp_path_factory.mktemp("b"))


def _screen(monkeypatch: pytest.MonkeyPatch, *args: str) -> str:
    """`openral-data ARGS` with stderr a 100-column terminal; what the terminal showed."""
    screen = io.StringIO()
    monkeypatch.setattr(terminal, "err_console", Console(file=screen, force_terminal=True, width=100))
    run = run_inproc(*args)
    assert run.returncode == 0, run.stderr
    return screen.getvalue()


@pytest.mark.parametrize(
    "args",
    [
        ["episodes", "merge", "{a}", "{b}", "--out", "{tmp}/m"],
        ["episodes", "split", "{a}", "--episodes", "0", "--out", "{tmp}/s", "--rest", "{tmp}/r"],
        ["episodes", "split", "{a}", "--fractions", "0.5,0.5", "--out-dir", "{tmp}/parts"],
    ],
)
def test_merge_and_split_show_the_episodes_written(
    datasets: tuple[Path, Path], tmp_path: Path, monkeypatch: pytest.MonkeyPatch, args: list[str]
) -> None:
    a, b = datasets
    argv = [x.format(a=a, b=b, tmp=tmp_path) for x in args]
    shown = _screen(monkeypatch, *argv)
    assert "writing" in shown and "episodes" in shown, shown
    quiet = [x.format(a=a, b=b, tmp=tmp_path / "q") for x in args]
    assert "writing" not in _screen(monkeypatch, *quiet, "-q")


def test_push_shows_the_files_sent(datasets: tuple[Path, Path], monkeypatch: pytest.MonkeyPatch) -> None:
    from huggingface_hub import constants

    monkeypatch.setenv("HF_TOKEN", "hf_test_token")
    monkeypatch.setattr(constants, "HF_HUB_OFFLINE", False)
    with local_hub() as (endpoint, received):
        monkeypatch.setattr(constants, "ENDPOINT", endpoint)
        shown = _screen(monkeypatch, "push", str(datasets[0]), "me/shown")
        quiet = _screen(monkeypatch, "push", str(datasets[0]), "me/quiet", "-q")
    assert "pushing" in shown and "files" in shown, shown
    assert "pushing" not in quiet
    assert len(received.commits) == 2
