"""A small mock recording made by the real CLI, for tests that damage or inspect a dataset of ours."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from tests.support.cli import run_cli
from tests.support.home import isolated_home
from tests.support.inproc import run_inproc
from tests.support.scenes import mock_scene, write_yaml


def record_mock_cli(base: Path, success_after: list[int], **scene: Any) -> Path:
    """`record` (h264) of one mock episode per entry of `success_after`, in a project home under `base`;
    returns the dataset folder `base/ds`."""
    path = write_yaml(
        base / "scene.yaml", mock_scene(success_after=success_after, n_episodes=len(success_after), **scene)
    )
    out = base / "ds"
    with isolated_home(base):
        done = run_cli("record", "--scene", str(path), "--out", str(out), "--codec", "h264")
    assert done.returncode == 0, done.stderr
    return out


def record_small(base: Path) -> Path:
    """`record` (in-process, h264) of 2 mock episodes of 3 steps in a project home under `base`; returns `base/ds`."""
    out = base / "ds"
    with isolated_home(base):
        run = run_inproc("record", "--n-episodes", "2", "--max-steps", "3", "--codec", "h264", "--out", str(out))
    assert run.returncode == 0, run.stderr
    return out
