"""No stray outputs: `view` (no display) and `replay` without an output option write under the project's datasets/
and results/, never into the current folder; those folders and runs/ are git-ignored here."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from tests.support.home import REPO, isolated_home
from tests.support.inproc import run_inproc
from tests.support.recorded import record_small


def test_view_and_replay_write_under_the_project_not_the_cwd(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    ds = record_small(tmp_path)
    cwd = tmp_path / "elsewhere"
    cwd.mkdir()
    monkeypatch.chdir(cwd)
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with isolated_home(tmp_path) as home:
        viewed = run_inproc("view", str(ds), "--episode", "1")
        replayed = run_inproc("replay", str(ds), "--json")
    assert viewed.returncode == 0, viewed.stderr
    assert (home / "datasets" / "ds-episode-1.rrd").stat().st_size > 0
    assert replayed.returncode == 0, replayed.stderr
    (results,) = (home / "results").iterdir()
    assert results.name.startswith("ds--replay-actions--") and (results / "summary.json").is_file()
    assert json.loads(replayed.stdout)["results"] == str(results)
    assert list(cwd.iterdir()) == []


def test_the_default_outputs_are_git_ignored_here() -> None:
    names = ["datasets/a/meta/info.json", "datasets/a-episode-0.rrd", "results/r/summary.json", "runs/p/x/.done.json"]
    done = subprocess.run(["git", "check-ignore", *names], cwd=REPO, capture_output=True, text=True, check=False)
    assert done.stdout.split() == names, done.stderr
