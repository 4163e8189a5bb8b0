"""Recorded end-effector quaternions keep one sign within an episode (q and -q are one rotation): a top-down
gripper has qw near 0, where a per-frame `qw >= 0` rule wrote square waves into observation.state."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import yaml

from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from openral_data.runtime import registry
from tests.support.mujoco import expert_rskill, shipped_scene
from tests.support.scenes import write_yaml


def test_the_expert_s_quaternions_are_continuous_and_the_same_rotations() -> None:
    from openral_data.producers.sim.mujoco.scene import TabletopScene

    rskill = expert_rskill("pick_place")
    scene = TabletopScene(shipped_scene("pick_place"), registry.ROBOTS["franka_panda"], rskill, "pick_place")  # type: ignore[arg-type]
    policy = registry.POLICIES[rskill.policy](rskill)
    states, raw = [], []
    try:
        obs = scene.reset(0)
        policy.reset(0)
        for _ in range(120):
            states.append(obs.state[3:7].astype(np.float64))
            raw.append(scene.arm.ee_pose(scene.data)[1])
            obs = scene.step(policy.step(obs, obs.task)).observation
    finally:
        scene.close()
    q, r = np.array(states), np.array(raw)
    assert np.all(np.einsum("ij,ij->i", q[1:], q[:-1]) > 0)  # no jump between q and -q
    assert np.allclose(np.abs(np.einsum("ij,ij->i", q, r)), 1.0, atol=1e-5)  # each frame: the same rotation
    lead = next(v for v in q[0] if abs(v) > 1e-12)  # qw, or the first non-zero component when qw is 0
    assert lead > 0  # the first frame's convention
    assert np.any(np.einsum("ij,ij->i", r[1:], r[:-1]) < 0)  # the w >= 0 rule flips on this very episode


def test_a_recorded_pick_place_episode_has_no_quaternion_sign_flips(project: Path, tmp_path: Path) -> None:
    data = yaml.safe_load((project / "scenes/sim/tabletop_pick_place.yaml").read_text())
    for cam in data["scene"]["cameras"]:
        cam["width"] = cam["height"] = 32
    scene = write_yaml(project / "scenes/sim/small_pick_place.yaml", data)
    out = tmp_path / "pp"
    record(RecordOptions(scene=str(scene), rskill="scripted-pick-place", n_episodes=1, seed=0, out=out))
    table = pq.read_table(next((out / "data").rglob("*.parquet")), columns=["observation.state"])
    q = np.array(table.column("observation.state").to_pylist(), dtype=np.float64)[:, 3:7]
    assert len(q) > 20 and np.allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-5)
    assert np.all(np.einsum("ij,ij->i", q[1:], q[:-1]) > 0)
