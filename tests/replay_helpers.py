"""Helpers for the replay tests: real recordings (mock and MuJoCo tabletop_push) in an isolated project."""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import yaml
from conftest import REPO, mock_scene, write_yaml

from openral_data.record.options import RecordOptions, RecordSummary
from openral_data.record.sim import record

SMALL_FRONT = {"name": "front", "width": 64, "height": 64, "pos": [1.2, 0.0, 1.3], "lookat": [0.42, 0.0, 0.85]}


@contextmanager
def project_home(base: Path) -> Iterator[Path]:
    """A copy of the repo's manifests as OPENRAL_DATA_HOME for the duration (module-scoped fixtures use it)."""
    home = base / "project"
    if not home.exists():
        for sub in ("robots", "rskills", "scenes"):
            shutil.copytree(REPO / sub, home / sub)
    old = os.environ.get("OPENRAL_DATA_HOME")
    os.environ["OPENRAL_DATA_HOME"] = str(home)
    try:
        yield home
    finally:
        if old is None:
            os.environ.pop("OPENRAL_DATA_HOME", None)
        else:
            os.environ["OPENRAL_DATA_HOME"] = old


def small_push_scene(home: Path, **task: object) -> Path:
    """tabletop_push with one 64x64 front camera (rendering dominates; physics is the shipped scene's)."""
    data = yaml.safe_load((home / "scenes/sim/tabletop_push.yaml").read_text())
    data["scene"]["cameras"] = [SMALL_FRONT]
    data["task"].update(task)
    return write_yaml(home / "scenes/sim/small_push.yaml", data)


def record_push(home: Path, out: Path, n_episodes: int = 3, seed: int = 0) -> RecordSummary:
    scene = small_push_scene(home)
    return record(
        RecordOptions(scene=str(scene), rskill="scripted-push", n_episodes=n_episodes, seed=seed, out=out, codec="h264")
    )


def record_mock(home: Path, out: Path, success_after: list[int] | int = (4, 6, 9), max_steps: int = 8) -> RecordSummary:
    scene = write_yaml(
        home / "scenes/sim/mock_replay.yaml",
        mock_scene(scene_id="mock_replay", success_after=list(success_after), max_steps=max_steps, n_episodes=3),
    )
    return record(RecordOptions(scene=str(scene), rskill="random-mock", out=out, codec="h264"))
