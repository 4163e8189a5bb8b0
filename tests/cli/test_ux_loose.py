"""Loose ends of the everyday surface: `stats` of a folder holding datasets, `record --resume`'s summary."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from tests.support.home import isolated_home
from tests.support.inproc import run_inproc
from tests.support.recorded import record_small


def test_stats_of_a_folder_holding_datasets_groups_each(tmp_path: Path) -> None:
    ds = record_small(tmp_path / "rec")
    parent = tmp_path / "datasets"
    parent.mkdir()
    shutil.copytree(ds, parent / "a")
    shutil.copytree(ds, parent / "b")
    (parent / "notes").mkdir()  # a folder that is no dataset is passed over
    run = run_inproc("stats", str(parent), "--json")
    assert run.returncode == 0, run.stderr
    assert [g["dataset"] for g in json.loads(run.stdout)["groups"]] == ["a", "b"]
    empty = tmp_path / "empty"
    empty.mkdir()
    bad = run_inproc("stats", str(empty))
    assert bad.returncode == 2 and "nor a folder holding some" in bad.stderr


def test_resume_summary_counts_every_episode_of_the_dataset(tmp_path: Path) -> None:
    out = record_small(tmp_path)  # 2 episodes
    with isolated_home(tmp_path):
        run = run_inproc("record", "--resume", "--out", str(out), "--n-episodes", "3", "--max-steps", "3")
    assert run.returncode == 0, run.stderr
    row = next(line for line in run.stdout.splitlines() if line.strip().startswith("episodes"))
    assert row.split(None, 1)[1] == "3 (2 before, 1 added by this run)"


def test_default_output_names_are_short_and_numbered(tmp_path: Path) -> None:
    with isolated_home(tmp_path) as home:
        for _ in range(2):
            run = run_inproc("record", "--n-episodes", "1", "--max-steps", "2", "--codec", "h264", "--json")
            assert run.returncode == 0, run.stderr
        assert sorted(p.name for p in (home / "datasets").iterdir()) == ["mock_pick-1", "mock_pick-2"]
