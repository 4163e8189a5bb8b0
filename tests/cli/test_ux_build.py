"""`record` on a terminal says it is building the scene until the first episode starts (a first robosuite
build takes about a minute), then counts frames; `-q` shows nothing."""

from __future__ import annotations

import io
from pathlib import Path

import pytest
from rich.console import Console

from openral_data.cli import terminal
from tests.support.home import isolated_home
from tests.support.inproc import run_inproc


def _record(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, *flags: str) -> str:
    screen = io.StringIO()
    monkeypatch.setattr(terminal, "err_console", Console(file=screen, force_terminal=True, width=100))
    with isolated_home(tmp_path):
        run = run_inproc("record", "--n-episodes", "1", "--max-steps", "2", "--codec", "h264", *flags)
    assert run.returncode == 0, run.stderr
    return screen.getvalue()


def test_the_bar_says_the_scene_is_being_built(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    shown = _record(tmp_path, monkeypatch)
    assert "building the scene..." in shown and "2 frames" in shown


def test_quiet_shows_no_bar(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    assert "building the scene" not in _record(tmp_path, monkeypatch, "-q")
