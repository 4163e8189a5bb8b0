"""The OpenArm pair behind the HAL: lerobot 0.6.1's own OpenArmFollower and OpenArmLeader (Damiao motors,
`make_robot_from_config`, `make_teleoperator_from_config`) on two SIMULATED CAN buses at once (python-can's
`virtual` interface, one channel each; tests/support/damiao_bus.py answers the motors' frames), recorded through
the real CLI; and the robot's MuJoCo twin (the left arm of openarm-mujoco's MJCF).

The leader is moved by hand in the test after lerobot zeroed it; the follower's motors move as the arm's MuJoCo
twin does under their MIT targets. Every action recorded must be a position the leader's motors reported (decoded
from their feedback frames); the follower's motors must have received it as their MIT position target and its
state follow; lerobot 0.6.1 must load the dataset frame-exact.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import yaml

from tests.support.damiao_bus import LeaderHand, SimulatedDamiaoBus, TwinPhysics, write_openarm_calibration
from tests.support.hal import episode_infos, frames_table
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import loaded_episodes

ROBOT = "openarm_follower"
STEPS = 15


@pytest.fixture
def buses(project: Path) -> Iterator[tuple[SimulatedDamiaoBus, SimulatedDamiaoBus]]:
    """The follower's CAN bus (its motors moved by the arm's MuJoCo twin) and the leader's, the manifest pointing
    at both (virtual channels) with calibration files for both arms."""
    folder = project / "robots" / ROBOT
    with SimulatedDamiaoBus(physics=TwinPhysics(ROBOT)) as follower, SimulatedDamiaoBus() as leader:
        write_openarm_calibration(folder / "calibration" / "openarm_follower.json")
        write_openarm_calibration(folder / "calibration" / "openarm_leader.json")
        manifest = yaml.safe_load((folder / "robot.yaml").read_text())
        for key, bus in (("robot", follower), ("teleop", leader)):
            manifest["hardware"][key].update(port=bus.channel, can_interface="virtual", calibration_dir="calibration")
        (folder / "robot.yaml").write_text(yaml.safe_dump(manifest, sort_keys=False))
        yield follower, leader


@pytest.mark.slow
def test_the_openarm_leader_drives_the_follower_over_two_simulated_can_buses(
    tmp_path: Path, buses: tuple[SimulatedDamiaoBus, SimulatedDamiaoBus]
) -> None:
    follower, leader = buses
    out = tmp_path / "openarm"
    with LeaderHand(leader, period=4.0, ramp=2.0):  # ≤ 45°/s: a tick late under load stays inside the 180°/s limit
        r = run_inproc(
            "record", "--hal", ROBOT, "--mode", "real", "--teleop", "leader", "--fps", "10", "--max-steps",
            str(STEPS), "--out", str(out), "--codec", "h264", "--operator", "success",
        )  # fmt: skip
    assert r.returncode == 0, r.stderr
    cols = frames_table(out)
    action, state = np.array(cols["action"]), np.array(cols["observation.state"])
    assert action.shape == (STEPS, 8)

    # every action value the safety filter left alone is a reading of that leader motor, in time order (a motor
    # whose reply came late keeps its last reading: lerobot's packet-drop rule)
    free = np.array(cols["openral.safety_interventions"]) == 0
    assert free.mean() >= 0.8, episode_infos(out)[0]["hal"]["intervention_log"]
    for j, name in enumerate(leader.motors):
        reads, at = np.array(leader.reported[name]), 0
        for value in action[free, j]:
            at += int(np.argmin(np.abs(reads[at:] - value)))
            assert abs(reads[at] - value) < 1e-3, (name, value, reads)
    assert np.ptp(action[:, 3]) > 10.0 and np.ptp(action[:, 7]) > 5.0  # the hand moved elbow and gripper

    # the follower's motors received each action as their MIT position target (16-bit over ±12.5 rad)
    targets = np.array([follower.motors[m].targets[-STEPS:] for m in follower.motors]).T
    assert np.abs(targets - action).max() < 0.03
    # ... and followed: each state is close to an action a tick or two before (the driver reads the feedback
    # frames its previous commands left queued: lerobot collects MIT replies for only 1 ms)
    lag = min(np.median(np.abs(state[k:] - action[:-k])) for k in (1, 2, 3))
    assert lag < 1.0 and np.ptp(state[:, 3]) > 10.0

    # real protocol frames both ways: enabled, commanded, refreshed and released; the leader zeroed, never driven
    assert follower.seen["enable"] >= 8 and follower.seen["mit"] >= 8 * STEPS and follower.seen["unknown"] == 0
    assert follower.seen["refresh"] >= 8 * STEPS and follower.seen["disable"] >= 8
    assert not any(m.enabled for m in follower.motors.values())  # torque released at the end
    assert leader.seen["zero"] == 8 and leader.seen["mit"] == 0 and leader.seen["refresh"] >= 8 * STEPS
    info = episode_infos(out)[0]
    assert info["operator"] == "teleop:openarm_leader" and info["hal"]["verdict"] == "success"

    loaded = loaded_episodes(out)  # lerobot 0.6.1's own loader: frame-exact
    assert np.array_equal(np.array([f["action"] for f in loaded[0]], dtype=np.float32), action.astype(np.float32))
    assert np.array_equal(np.array([f["state"] for f in loaded[0]], dtype=np.float32), state.astype(np.float32))


def test_the_openarm_twin_hangs_from_its_shoulder_at_zero_and_its_gripper_opens_at_minus_65() -> None:
    """The twin (the left arm of openarm-mujoco's MJCF) speaks lerobot's units: at 0 the arm hangs straight down
    (lerobot's calibration pose), the elbow (joint_4) at 90 degrees brings the hand up to the elbow's height, and
    the gripper motor's -65 (open) .. 0 (closed) opens and closes the fingers."""
    import mujoco

    from openral_data.producers.sim.mujoco.twin import Twin
    from openral_data.runtime import registry

    twin = Twin(registry.ROBOTS[ROBOT], [])
    model = twin.model
    data = mujoco.MjData(model)
    ee = model.site("robot/left_ee_control_point").id
    shoulder, elbow = (model.body(f"robot/openarm_left_link{k}").id for k in (2, 4))
    fingers = [model.joint(f"robot/openarm_left_finger_joint{k}").qposadr[0] for k in (1, 2)]

    def settle(target: list[float]) -> np.ndarray:
        twin.command(data, np.array(target))
        mujoco.mj_step(model, data, nstep=500)  # 1 s
        return twin.state(data)

    twin.hold_home(data)
    state = settle([0, 0, 0, 0, 0, 0, 0, -65])
    assert np.abs(state[:7]).max() < 0.5 and state[7] < -60, state
    drop = data.xpos[shoulder] - data.site_xpos[ee]
    assert np.hypot(drop[0], drop[1]) < 0.1 and drop[2] > 0.4, drop  # straight below the shoulder
    opened = data.qpos[fingers].copy()
    state = settle([0, 0, 0, 90, 0, 0, 0, 0])
    assert abs(state[3] - 90) < 2 and state[7] > -5, state
    assert abs(data.xpos[elbow][2] - data.site_xpos[ee][2]) < 0.05, data.site_xpos[ee]  # forearm level: hand came up
    assert np.all(opened > 0.7) and np.all(data.qpos[fingers] < 0.05), (opened, data.qpos[fingers])


def test_a_share_asset_is_found_under_the_environments_share_folder_and_never_outside(tmp_path: Path) -> None:
    """`share://` (openarm-mujoco's MJCF is a wheel data file, not inside its package) resolves under
    sysconfig's data path; a reference leading out is refused, a missing one named."""
    import sysconfig

    from openral_data.errors import ConfigError, DatasetError
    from openral_data.producers.sim.mujoco.assets import resolve_asset

    share = Path(sysconfig.get_path("data")) / "share"
    found = resolve_asset("share://openarm_mujoco/v2/openarm_bimanual.xml", tmp_path, "robot.yaml: assets.mjcf")
    assert found == share / "openarm_mujoco/v2/openarm_bimanual.xml" and found.is_file()
    with pytest.raises(DatasetError, match=r"robot\.yaml: assets\.mjcf: share://\.\./\.\./etc/passwd: .*leads outside"):
        resolve_asset("share://../../etc/passwd", tmp_path, "robot.yaml: assets.mjcf")
    with pytest.raises(ConfigError, match=r"share://openarm_mujoco/v9/none\.xml: no such file"):
        resolve_asset("share://openarm_mujoco/v9/none.xml", tmp_path, "robot.yaml: assets.mjcf")
