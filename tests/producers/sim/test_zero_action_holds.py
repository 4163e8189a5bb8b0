"""A zero delta action holds the end effector where it is: the position target is the previous target plus the
delta, not the arm's current (sagging under gravity) pose plus the delta, so an operator's pause is idle data."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import numpy.typing as npt
import pyarrow.parquet as pq
import pytest
import yaml

from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from openral_data.runtime import registry
from openral_data.schemas.rskill import RSkillManifest
from openral_data.types import Observation
from tests.support.inproc import run_inproc
from tests.support.mujoco import make_scene
from tests.support.scenes import write_yaml

FPS, PAUSE = 20, 40  # the scene's rate; 2 s of zero actions


def test_two_seconds_of_zero_actions_keep_the_end_effector_within_a_millimetre() -> None:
    scene = make_scene("pick_place")
    try:
        scene.reset(0)
        start = scene.arm.ee_pose(scene.data)[0]
        path = [scene.step(np.zeros(7, np.float32)).observation.state[:3] for _ in range(2 * FPS)]
    finally:
        scene.close()
    drift = np.linalg.norm(np.array(path, dtype=np.float64) - start, axis=1)
    assert drift.max() < 1e-3, drift.max()


class PauseThenExpert:
    """What an operator does who waits 2 s before driving: zeros, then the scripted expert."""

    def __init__(self, rskill: RSkillManifest) -> None:
        self.expert = registry.POLICIES["scripted_pick_place"](rskill)
        self.t = 0

    def reset(self, seed: int) -> None:
        self.expert.reset(seed)
        self.t = 0

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        self.t += 1
        if self.t <= PAUSE:
            return np.zeros(7, dtype=np.float32)
        return self.expert.step(observation, instruction)

    def close(self) -> None:
        self.expert.close()


def test_trim_idle_finds_the_pause_at_the_head_of_a_recorded_episode(
    project: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    data = yaml.safe_load((project / "scenes/sim/tabletop_pick_place.yaml").read_text())
    for cam in data["scene"]["cameras"]:
        cam["width"] = cam["height"] = 32
    scene = write_yaml(project / "scenes/sim/small_pick_place.yaml", data)
    monkeypatch.setitem(registry.POLICIES, "pause_then_expert", PauseThenExpert)
    rskill = yaml.safe_load((project / "rskills/scripted-pick-place/rskill.yaml").read_text())
    rskill.update(id="pause-then-expert", policy="pause_then_expert")
    write_yaml(project / "rskills/pause-then-expert/rskill.yaml", rskill)
    src, out = tmp_path / "paused", tmp_path / "trimmed"
    record(RecordOptions(scene=str(scene), rskill="pause-then-expert", n_episodes=1, seed=0, out=src, max_steps=80))
    res = run_inproc("episodes", "trim", str(src), "--idle", "--min-frames", "6", "--out", str(out))
    assert res.returncode == 0, res.stderr
    before = pq.read_table(next((src / "data").rglob("*.parquet")), columns=["observation.state"])
    after = pq.read_table(next((out / "data").rglob("*.parquet")), columns=["observation.state"])
    dropped = before.num_rows - after.num_rows
    assert PAUSE - 3 <= dropped <= PAUSE + 1, dropped  # the pause, give or take the frames the motion starts on
    first_moving = np.array(before.column("observation.state")[dropped].as_py())
    assert np.allclose(np.array(after.column("observation.state")[0].as_py()), first_moving)
