"""Native MuJoCo tabletop scenes: composition for every robot, determinism, restore, control, cameras."""

from __future__ import annotations

import json

import numpy as np
import pytest

# CompatibilityError and ConfigError raises are matched by message on purpose: the file and field it names are the point
from openral_data.errors import CompatibilityError, ConfigError
from openral_data.runtime import registry
from openral_data.types import SimRollout
from tests.support.home import REPO
from tests.support.mujoco import FRONT, OVERHEAD, WRIST, joint_rskill, make_scene, project, red_mask, run_expert

# robots with MuJoCo wiring for the tabletop scenes (the SO arms' wiring is for their twin only: `tabletop: false`)
SHIPPED = [
    r
    for r in registry.robot_ids()
    if r != "mock_arm" and (sim := registry.ROBOTS[r].sim) is not None and sim.get("tabletop", True) is not False
]


def test_every_shipped_robot_is_wired() -> None:
    assert {"franka_panda", "ur5e", "sawyer"} <= set(SHIPPED)


@pytest.mark.parametrize("robot", SHIPPED)
def test_composition_compiles_and_sizes_come_from_the_model(robot: str) -> None:
    manifest = registry.ROBOTS[robot]
    n_arm = len([j for j in manifest.joints if j.type != "gripper"])
    scene = make_scene("push", robot, cameras=[WRIST])
    try:
        assert isinstance(scene, SimRollout)
        assert scene.spec.action_dim == 7 and scene.spec.state_dim == 8 and scene.spec.can_restore_state
        assert scene.arm.n == n_arm
        obs = scene.reset(0)
        # the ready posture: grasp site at ready_xy, 25 cm above the table, pointing down, gripper open
        pos, _ = scene.arm.ee_pose(scene.data)
        assert np.allclose(pos, [0.38, 0.0, 0.8 + 0.25], atol=0.01)
        zaxis = scene.data.site_xmat[scene.arm.site].reshape(3, 3)[:, 2]
        assert zaxis[2] < -0.99
        assert obs.state.shape == (8,) and obs.state[7] < 0.1
        assert obs.images["wrist"].shape == (64, 64, 3) and obs.images["wrist"].std() > 5  # the wrist mount works
    finally:
        scene.close()
    joint = make_scene("pick_place", robot, rskill=joint_rskill(n_arm))
    try:
        assert joint.spec.action_dim == n_arm + 1 and joint.spec.state_dim == n_arm + 1
    finally:
        joint.close()


def test_robot_base_pose_comes_from_the_scene_yaml() -> None:
    scene = make_scene("push", params={"base_pos": [-0.05, 0.1, 0.8], "base_yaw": 0.3})
    try:
        scene.reset(0)
        base = scene.model.body("robot/base").id
        assert np.allclose(scene.data.xpos[base], [-0.05, 0.1, 0.8])
        heading = scene.data.xmat[base].reshape(3, 3)[:, 0]
        assert np.isclose(np.arctan2(heading[1], heading[0]), 0.3)
        pos, _ = scene.arm.ee_pose(scene.data)
        assert np.allclose(pos, [0.38, 0.0, 1.05], atol=0.01)  # the ready pose is still reached
    finally:
        scene.close()


def _rollout(scene: object, seed: int, steps: int = 25) -> list[np.ndarray]:
    from openral_data.producers.sim.mujoco.scene import TabletopScene

    assert isinstance(scene, TabletopScene)
    rng = np.random.default_rng(123)
    out = [scene.reset(seed).state]
    for _ in range(steps):
        action = rng.uniform([-0.02] * 3 + [-0.05] * 3 + [0], [0.02] * 3 + [0.05] * 3 + [1]).astype(np.float32)
        out.append(scene.step(action).observation.state)
    out.append(scene.data.qpos.copy())
    return out


def test_same_seed_same_initial_state_and_rollout() -> None:
    a, b = make_scene("push"), make_scene("push")
    try:
        first = _rollout(a, 7)
        state_a = a.initial_state()
        second = _rollout(b, 7)
        assert json.dumps(state_a) == json.dumps(b.initial_state())
        assert all(np.array_equal(x, y) for x, y in zip(first, second, strict=True))
        other = _rollout(b, 8)
        assert b.initial_state()["cube_pose"] != state_a["cube_pose"]
        assert not np.array_equal(first[-1], other[-1])
    finally:
        a.close()
        b.close()


def test_initial_state_is_json_and_restores_the_exact_rollout() -> None:
    scene = make_scene("pick_place")
    try:
        reference = _rollout(scene, 11)
        saved = json.loads(json.dumps(scene.initial_state()))
        assert saved["seed"] == 11 and len(saved["cube_pose"]) == 7 and len(saved["goal_pos"]) == 3
        _rollout(scene, 99)  # wander elsewhere first
        restored = scene.reset_to(saved)
        assert np.array_equal(restored.state, reference[0])
        rng = np.random.default_rng(123)
        replay = [restored.state]
        for _ in range(25):
            action = rng.uniform([-0.02] * 3 + [-0.05] * 3 + [0], [0.02] * 3 + [0.05] * 3 + [1]).astype(np.float32)
            replay.append(scene.step(action).observation.state)
        replay.append(scene.data.qpos.copy())
        assert all(np.array_equal(x, y) for x, y in zip(reference, replay, strict=True))
        with pytest.raises(ConfigError, match="initial_state: format"):
            scene.reset_to({"qpos": []})
        with pytest.raises(ConfigError, match="initial_state: task: recorded on 'push'"):
            scene.reset_to({**saved, "task": "push"})
    finally:
        scene.close()


def test_joint_position_actions_are_tracked() -> None:
    scene = make_scene("push", rskill=joint_rskill(7))
    try:
        obs = scene.reset(0)
        target = obs.state.copy()
        target[:7] += np.array([0.15, -0.1, 0.1, 0.1, -0.1, 0.1, 0.2], dtype=np.float32)
        target[7] = 1.0
        for _ in range(30):
            obs = scene.step(target).observation
        assert np.abs(obs.state[:7] - target[:7]).max() < 0.01
        assert obs.state[7] > 0.9  # the fingers closed on nothing
        target[7] = 0.0
        for _ in range(15):
            obs = scene.step(target).observation
        assert obs.state[7] < 0.1
    finally:
        scene.close()


def test_eef_delta_actions_move_the_end_effector() -> None:
    scene = make_scene("push")
    try:
        start = scene.reset(0).state[:3].copy()
        for _ in range(20):
            obs = scene.step(np.array([0.01, -0.005, -0.004, 0, 0, 0, 0], dtype=np.float32)).observation
        moved = (obs.state[:3] - start).astype(np.float64)
        commanded = np.array([0.2, -0.1, -0.08])
        cosine = moved @ commanded / (np.linalg.norm(moved) * np.linalg.norm(commanded))
        # each delta is measured from the current pose: the servos cover most of it within the 50 ms step
        assert cosine > 0.995 and 0.6 < np.linalg.norm(moved) / np.linalg.norm(commanded) <= 1.02, moved
        assert obs.time == pytest.approx(20 / 20)  # simulation time since reset
    finally:
        scene.close()


def test_cameras_show_the_scene() -> None:
    scene = make_scene("push", cameras=[FRONT, OVERHEAD, WRIST])
    try:
        obs = scene.reset(3)
        front, over, wrist = obs.images["front"], obs.images["overhead"], obs.images["wrist"]
        assert front.shape == (96, 96, 3) and wrist.shape == (64, 64, 3) and front.dtype == np.uint8
        for img in (front, over, wrist):
            assert img.std() > 10  # not a constant frame
        assert np.abs(front.astype(int) - over.astype(int)).mean() > 10
        # the red cube appears where MuJoCo's camera model projects its centre, in both world cameras
        cube = scene.cube_pos()
        for name, img in (("front", front), ("overhead", over)):
            mask = red_mask(img)
            assert mask.sum() >= 4, name
            rows, cols = np.nonzero(mask)
            col, row = project(scene, name, cube)
            assert abs(cols.mean() - col) < 4 and abs(rows.mean() - row) < 4, (name, cols.mean(), col)
        # another seed moves the cube, and the red pixels move with it
        obs2 = scene.reset(4)
        moved = red_mask(obs2.images["overhead"])
        assert not np.array_equal(moved, red_mask(over))
        col, row = project(scene, "overhead", scene.cube_pos())
        rows, cols = np.nonzero(moved)
        assert abs(cols.mean() - col) < 4 and abs(rows.mean() - row) < 4
    finally:
        scene.close()


def test_shadows_and_reflections_are_off_by_default_and_on_from_the_yaml() -> None:
    import mujoco

    from openral_data.schemas.scene import RenderConfig

    plain = make_scene("push", cameras=[FRONT])
    fancy = make_scene(
        "push", cameras=[FRONT], render=RenderConfig(shadows=True, reflections=True, robot_meshes="visual")
    )
    try:
        flags = mujoco.mjtRndFlag
        plain_r, fancy_r = plain.rig._renderers["front"], fancy.rig._renderers["front"]
        assert not plain_r.scene.flags[flags.mjRND_SHADOW] and not plain_r.scene.flags[flags.mjRND_REFLECTION]
        assert fancy_r.scene.flags[flags.mjRND_SHADOW] and fancy_r.scene.flags[flags.mjRND_REFLECTION]
        a, b = plain.reset(0).images["front"], fancy.reset(0).images["front"]
        assert np.abs(a.astype(int) - b.astype(int)).mean() > 1  # shadows and detailed meshes change the picture
        assert red_mask(b).sum() >= 4
    finally:
        plain.close()
        fancy.close()


def test_unsupported_contracts_and_bad_wiring_are_named() -> None:
    rs = joint_rskill(7)
    bad = rs.model_copy(
        update={"action_contract": rs.action_contract.model_copy(update={"representation": "eef_pose"})}
    )
    with pytest.raises(CompatibilityError, match=r"action_contract\.representation: 'eef_pose' is not accepted"):
        make_scene("push", rskill=bad)
    with pytest.raises(ConfigError, match=r"scene\.cameras\[0\]: a world camera needs pos and lookat"):
        make_scene("push", cameras=[FRONT.model_copy(update={"pos": None})])


def _expert_results(kind: str, seeds: range) -> list[bool]:
    scene = make_scene(kind)
    try:
        return [run_expert(scene, seed, 250)[0] for seed in seeds]
    finally:
        scene.close()


@pytest.mark.parametrize("kind", ["push", "pick_place"])
def test_expert_succeeds_on_a_few_seeds(kind: str) -> None:
    results = _expert_results(kind, range(4))
    assert sum(results) >= 3, results


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["push", "pick_place"])
def test_expert_success_rate_on_franka_seeds_0_to_49(kind: str) -> None:
    results = _expert_results(kind, range(50))
    assert sum(results) / 50 >= 0.8, [s for s, ok in enumerate(results) if not ok]


def test_headless_backends_default_egl_and_osmesa_fallback_render() -> None:
    import os
    import subprocess
    import sys

    code = (
        "import os\n"
        "import openral_data.producers.sim.mujoco as m\n"
        "from tests.support.mujoco import FRONT, make_scene, red_mask\n"
        "s = make_scene('push', cameras=[FRONT])\n"
        "img = s.reset(3).images['front']\n"
        "s.close()\n"
        "print(os.environ['MUJOCO_GL'], int(red_mask(img).sum()), float(img.std()))\n"
    )
    for backend in (None, "osmesa"):
        env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
        if backend:
            env["MUJOCO_GL"] = backend
        env["PYTHONPATH"] = str(REPO) + os.pathsep + env.get("PYTHONPATH", "")
        proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=False)
        assert proc.returncode == 0, proc.stderr[-2000:]
        name, red, std = proc.stdout.split()
        assert name == (backend or "egl") and int(red) >= 4 and float(std) > 10
