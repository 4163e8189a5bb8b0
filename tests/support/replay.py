"""Helpers for the replay tests: real recordings (mock and MuJoCo tabletop_push) in an isolated project."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import yaml

from openral_data.record.options import RecordOptions, RecordSummary
from openral_data.record.sim import record
from tests.support.scenes import mock_scene, write_yaml

SMALL_FRONT = {"name": "front", "width": 64, "height": 64, "pos": [1.2, 0.0, 1.3], "lookat": [0.42, 0.0, 0.85]}


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


def record_mock(home: Path, out: Path, success_after: Sequence[int] = (4, 6, 9), max_steps: int = 8) -> RecordSummary:
    scene = write_yaml(
        home / "scenes/sim/mock_replay.yaml",
        mock_scene(scene_id="mock_replay", success_after=list(success_after), max_steps=max_steps, n_episodes=3),
    )
    return record(RecordOptions(scene=str(scene), rskill="random-mock", out=out, codec="h264"))
