"""robosuite scenes (robosuite 1.5.1, Panda + OSC_POSE): contracts, seeds, restore, upright cameras, records."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from openral_data.errors import CompatibilityError, ConfigError
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from openral_data.runtime import registry
from openral_data.schemas.rskill import Contract, RSkillManifest
from openral_data.types import SimRollout
from tests.support.suites import (
    env_and_policy,
    project_point,
    replay_reproduces,
    rollout,
    shipped,
    small_scene_file,
    stats_groups,
)

pytest.importorskip("robosuite")

RANDOM = "robosuite-panda-random"
SIZE = 96


@pytest.fixture(scope="module")
def lift() -> Iterator[tuple[SimRollout, Any]]:
    """One Lift scene (agentview 96², eye-in-hand 64²) shared by the tests that only reset and step it."""
    env, policy = env_and_policy(
        "robosuite_lift", RANDOM, cameras=[("agentview", SIZE, SIZE), ("robot0_eye_in_hand", 64, 64)]
    )
    yield env, policy
    env.close()


def _joint_rskill(representation: str = "joint_positions_gripper") -> RSkillManifest:
    base = registry.resolve_rskill(RANDOM)[0]
    names = [f"q{k}" for k in range(7)] + ["gripper"]
    state = Contract(dim=8, names=names, representation=representation)  # type: ignore[arg-type]
    return base.model_copy(update={"state_contract": state})


def test_scene_speaks_the_rskill_contract_and_refuses_what_it_cannot(lift: tuple[SimRollout, Any]) -> None:
    env = lift[0]
    assert isinstance(env, SimRollout)
    assert env.spec.state_dim == 8 and env.spec.action_dim == 7 and env.spec.fps == 20
    assert env.spec.can_restore_state
    obs = env.reset(1)
    pos, quat, grip = obs.state[:3], obs.state[3:7], obs.state[7]
    assert np.allclose(pos, obs.privileged["eef_pos"], atol=1e-6)
    assert abs(np.linalg.norm(quat) - 1) < 1e-5 and quat[0] >= 0 and 0 <= grip <= 1
    assert "cube_pos" in obs.privileged and obs.time == 0.0
    result = env.step(np.zeros(7, dtype=np.float32))
    assert result.observation.time == pytest.approx(0.05) and result.success is False

    scene = shipped("robosuite_lift", cameras=[])
    robot = registry.ROBOTS["franka_panda"]
    joints = registry.SCENES["robosuite"](scene, robot, _joint_rskill(), "lift.yaml")
    try:
        state = joints.reset(1).state
        assert joints.spec.state_dim == 8 and state.shape == (8,) and np.abs(state[:7]).max() < 3.0
    finally:
        joints.close()
    with pytest.raises(CompatibilityError, match=r"state_contract\.representation: 'joint_positions' is not produced"):
        registry.SCENES["robosuite"](scene, robot, _joint_rskill("joint_positions"), "lift.yaml")
    with pytest.raises(
        ConfigError,
        match=r"lift\.yaml: scene\.robot: robosuite scenes support franka_panda, unitree_g1, .*, got .ur5e.",
    ):
        registry.SCENES["robosuite"](scene, registry.ROBOTS["ur5e"], _joint_rskill(), "lift.yaml")


def test_seed_is_one_initial_state_and_reset_to_replays_bit_for_bit() -> None:
    """Door places the door by editing the model (body_pos), not a joint: the snapshot must carry it."""
    env, policy = env_and_policy("robosuite_door", RANDOM)
    try:
        obs = env.reset(21)
        policy.reset(21)
        initial = json.loads(json.dumps(env.initial_state()))
        first = rollout(env, policy, obs, 30)
        env.reset(22)
        assert env.initial_state()["mujoco"]["body_pos"] != initial["mujoco"]["body_pos"]  # the door moved
        env.step(np.ones(7, dtype=np.float32))
        restored = env.reset_to(initial)
        assert list(initial["object_poses"]) == ["Door"]  # replay compares these with the restored ones
        assert restored.privileged["object_poses"]["Door"].tolist() == initial["object_poses"]["Door"]
        again = rollout(env, policy, restored, 30, actions=first["actions"])
        assert np.array_equal(again["states"], first["states"])
        assert again["rewards"] == first["rewards"] and again["successes"] == first["successes"]

        tampered = json.loads(json.dumps(initial))
        tampered["mujoco"]["integration_state"][1] += 1e-3
        with pytest.raises(ConfigError, match="initial_state: mujoco: robosuite's reset with seed 21 does not"):
            env.reset_to(tampered)
        with pytest.raises(ConfigError, match="initial_state: env: recorded on 'Lift', this scene is 'Door'"):
            env.reset_to({**initial, "env": "Lift"})
    finally:
        env.close()


def _near(mask: np.ndarray, row: int, col: int) -> bool:
    return bool(mask[max(row - 1, 0) : row + 2, max(col - 1, 0) : col + 2].any())


def test_agentview_is_upright_cube_and_hand_are_where_the_geometry_says(lift: tuple[SimRollout, Any]) -> None:
    """agentview looks at the table from the front: the hand starts high above it (top of an upright image, where
    the mirrored spot is bare white table) and the red cube lies on it."""
    size, env = SIZE, lift[0]
    model, data = env.model, env.data  # type: ignore[attr-defined]
    for seed in (1, 2):
        obs = env.reset(seed)
        img = obs.images["agentview"].astype(int)
        assert obs.images["robot0_eye_in_hand"].shape == (64, 64, 3)
        red = (img[..., 0] > 100) & (img[..., 1] < 60) & (img[..., 2] < 60)
        table = img.min(axis=2) > 200
        row, col = project_point(model, data, "agentview", obs.privileged["cube_pos"], size, size)
        assert _near(red, row, col), (seed, row, col)
        row, col = project_point(model, data, "agentview", obs.privileged["eef_pos"], size, size)
        assert row < size // 3 and not _near(table, row, col), (seed, row, col)
        assert table[size - 2 - row : size + 1 - row, col - 1 : col + 2].all()  # upside down would put it here


def test_recorded_lift_dataset_loads_in_lerobot_and_holds_what_was_stepped(
    project: Path, tmp_path: Path, lift: tuple[SimRollout, Any]
) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    scene = small_scene_file(project, "robosuite_lift", size=48)
    out = tmp_path / "lift"
    summary = record(RecordOptions(scene=str(scene), rskill=RANDOM, n_episodes=2, seed=4, max_steps=8, out=out))
    assert summary.frames == 16 and [e.success for e in summary.episodes] == [False, False]

    ds = LeRobotDataset("local/lift", root=out, video_backend="pyav")
    assert len(ds) == 16 and ds.fps == 20 and ds.meta.robot_type == "franka_panda"
    assert ds.meta.video_keys == ["observation.images.agentview", "observation.images.robot0_eye_in_hand"]
    table = ds.hf_dataset.with_format("numpy")
    episode = np.flatnonzero(np.asarray(table["episode_index"]) == 1)
    # the dataset holds exactly what the scene produced for seed 5 under the recorded actions
    env, policy = lift
    policy.reset(5)
    run = rollout(env, policy, env.reset(5), 8)
    assert np.array_equal(np.stack(table["observation.state"])[episode], run["states"][:8])
    assert np.array_equal(np.stack(table["action"])[episode], np.stack(run["actions"]))
    frame = (ds[int(episode[0])]["observation.images.agentview"].numpy() * 255).astype(int)
    assert frame.shape == (3, 48, 48) and frame.std() > 10
    initial = json.loads(ds.meta.episodes["openral.initial_state"][1])
    assert initial["seed"] == 5 and initial["env"] == "Lift" and initial["suite"] == "robosuite"
    replay_reproduces(out, tmp_path / "replay", episodes=2)


@pytest.mark.slow
@pytest.mark.parametrize(
    "scene_id", ["robosuite_stack_bench", "robosuite_pick_place_can_bench", "robosuite_door_bench"]
)
def test_every_robosuite_benchmark_records_loads_replays_and_reports(
    scene_id: str, project: Path, tmp_path: Path
) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    scene = small_scene_file(project, scene_id, size=48)
    out = tmp_path / scene_id
    # no rskill: the scene's default_rskill (robosuite-panda-random), as `record --scene ID` without --rskill
    summary = record(RecordOptions(scene=str(scene), n_episodes=2, max_steps=10, out=out))
    assert json.loads((out / ".openral/record.json").read_text())["options"]["rskill"].endswith(
        f"/{RANDOM}/rskill.yaml"
    )
    ds = LeRobotDataset(f"local/{scene_id}", root=out, video_backend="pyav")
    assert len(ds) == summary.frames == 20 and [int(x) for x in ds.meta.episodes["openral.seed"]] == [1000, 1001]
    replay_reproduces(out, tmp_path / "replay", episodes=2)
    (group,) = stats_groups(out)
    assert group["episodes"] == 2 and group["success_known"] == 2 and group["ci95_low"] <= group["success_rate"]


@pytest.mark.slow
def test_named_camera_depth_geometry_and_object_poses() -> None:
    """A model's own camera gets depth and its geometry through the same rig as the composed scenes; the task
    objects' poses are `observation.environment_state`."""
    from openral_data.producers.sim.mujoco.camera_geometry import project
    from openral_data.schemas.scene import ObservationsConfig, SceneCamera
    from tests.support.mujoco import red_mask
    from tests.support.suites import build

    scene = shipped("robosuite_lift")
    cams = [SceneCamera(name="agentview", width=SIZE, height=SIZE, depth=True)]
    update = {"cameras": cams, "observations": ObservationsConfig(environment_state=True)}
    env = build(scene.model_copy(update={"scene": scene.scene.model_copy(update=update)}), RANDOM)
    try:
        assert env.spec.cameras["agentview_depth"].depth_unit == "m"
        assert env.spec.environment_state_names == tuple(f"cube.{k}" for k in ("x", "y", "z", "qw", "qx", "qy", "qz"))
        obs = env.reset(1)
        cube = np.asarray(obs.privileged["object_poses"]["cube"], dtype=np.float32)
        assert obs.environment_state is not None and np.array_equal(obs.environment_state, cube)
        depth = obs.images["agentview_depth"]
        assert depth.dtype == np.float32 and depth.shape == (SIZE, SIZE)
        u, v = project(env.spec.cameras["agentview"].info, cube[:3])
        rows, cols = np.nonzero(red_mask(obs.images["agentview"]))
        assert rows.size >= 5 and abs(cols.mean() - u) < 2.0 and abs(rows.mean() - v) < 2.0, (u, v)
        assert 0.3 < float(depth[round(v), round(u)]) < 1.5
    finally:
        env.close()
