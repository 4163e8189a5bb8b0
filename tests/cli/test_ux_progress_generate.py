"""`generate` (minutes for a real campaign) shows its progress on a terminal: first that it replays the source
demonstrations, then the episodes kept and their frames; `-q` shows nothing."""

from __future__ import annotations

import io
from pathlib import Path

import pytest
from rich.console import Console

from openral_data.cli import terminal
from tests.generate.test_generate import small_scene
from tests.support.inproc import run_inproc


@pytest.mark.slow  # records two MuJoCo demonstrations, then generates from them twice
def test_generate_shows_the_episodes_kept(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    scene = small_scene(tmp_path, "pick_place")
    src = tmp_path / "src"
    assert run_inproc("record", "--scene", str(scene), "--n-episodes", "2", "--out", str(src), "--codec", "h264",
                      "-q").returncode == 0  # fmt: skip
    shown: dict[str, str] = {}
    for name, flags in (("bar", []), ("quiet", ["-q"])):
        screen = io.StringIO()
        monkeypatch.setattr(terminal, "err_console", Console(file=screen, force_terminal=True, width=100))
        run = run_inproc("generate", str(src), "--scene", str(scene), "--n", "2", "--out", str(tmp_path / name),
                         "--codec", "h264", *flags)  # fmt: skip
        assert run.returncode == 0, run.stderr
        shown[name] = screen.getvalue()
    assert "generating" in shown["bar"] and "replaying the source demonstrations..." in shown["bar"]
    assert "episodes kept" in shown["bar"] and " frames" in shown["bar"]
    assert "generating" not in shown["quiet"]
