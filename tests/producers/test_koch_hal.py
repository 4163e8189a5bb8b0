"""The Koch pair behind the HAL: lerobot 0.6.1's own KochFollower and KochLeader (`make_robot_from_config`,
`make_teleoperator_from_config`) on two SIMULATED Dynamixel Protocol 2.0 buses at once (tests/support/
dynamixel_bus.py, one pty each; dynamixel_sdk unchanged), recorded through the real CLI.

The leader is moved by hand in the test: a thread turns its servos' shafts. Every action recorded must be what the
leader's bus reported at that tick, converted by lerobot's calibration (-100..100 of each calibrated range, the
gripper 0..100); the follower's state must follow; lerobot 0.6.1 must load the dataset frame-exact.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from openral_data.errors import HalError
from openral_data.record.hal import HalRecordOptions, record_hal
from tests.support.dynamixel_bus import (
    KOCH_FOLLOWER_MODELS,
    KOCH_LEADER_MODELS,
    KOCH_RANGES,
    LEADER_DRIVE_MODES,
    SimulatedDynamixelBus,
    normalized,
    write_koch_calibration,
)
from tests.support.hal import calibrated_leader_manifest, episode_infos, frames_table
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import loaded_episodes
from tests.support.servo_hand import actions_are_reads, record_by_hand

ROBOT = "koch_follower"
IDS = list(range(1, 7))
STEPS = 15


def _manifest(project: Path, leader_port: str) -> Path:
    """The Koch manifest with calibration files for both arms and the leader on `leader_port`."""
    folder = project / "robots" / ROBOT
    write_koch_calibration(folder / "calibration" / "koch_follower.json")
    write_koch_calibration(folder / "calibration" / "koch_leader.json", LEADER_DRIVE_MODES)
    return calibrated_leader_manifest(folder / "robot.yaml", leader_port)


@pytest.fixture
def buses(project: Path) -> Iterator[tuple[SimulatedDynamixelBus, SimulatedDynamixelBus]]:
    """The follower's and the leader's bus (the leader's elbow mounted reversed), the manifest pointing at both."""
    with (
        SimulatedDynamixelBus(KOCH_FOLLOWER_MODELS) as follower,
        SimulatedDynamixelBus(KOCH_LEADER_MODELS, drive_modes=LEADER_DRIVE_MODES) as leader,
    ):
        _manifest(project, leader.port)
        yield follower, leader


@pytest.mark.slow
def test_the_koch_leader_drives_the_follower_over_two_simulated_dynamixel_buses(
    tmp_path: Path, buses: tuple[SimulatedDynamixelBus, SimulatedDynamixelBus]
) -> None:
    follower, leader = buses
    out = tmp_path / "koch"
    r = record_by_hand([leader], ROBOT, out, STEPS, "--port", follower.port)
    assert r.returncode == 0, r.stderr
    cols = frames_table(out)
    action, state = np.array(cols["action"]), np.array(cols["observation.state"])
    assert len(action) == STEPS
    # every action is what the leader's bus reported at that tick (one of its reads, in order)
    actions_are_reads(action, [[normalized(r[i], i, KOCH_RANGES) for i in IDS] for r in leader.position_reads])
    assert np.ptp(action[:, 1]) > 3.0  # the hand moved the leader
    # the follower's servos follow: readings close to the previous frame's command (a tick the loaded machine
    # started late may read the servos before they arrived: most, not all)
    lag = np.abs(state[1:, :5] - action[:-1, :5])
    assert np.median(lag) < 1.0 and np.mean(lag < 3.0) >= 0.8, lag
    assert np.abs(state[1:] - state[:-1]).max() > 0.5
    assert not any(s.get("torque") for s in [*follower.servos.values(), *leader.servos.values()])  # released
    info = episode_infos(out)[0]
    assert info["operator"] == "teleop:koch_leader" and info["hal"]["verdict"] == "success"

    loaded = loaded_episodes(out)  # lerobot 0.6.1's own loader: frame-exact
    assert np.array_equal(np.array([f["action"] for f in loaded[0]], dtype=np.float32), action.astype(np.float32))
    assert np.array_equal(np.array([f["state"] for f in loaded[0]], dtype=np.float32), state.astype(np.float32))


def test_a_koch_arm_whose_motors_disagree_with_its_calibration_file_is_one_line(project: Path, tmp_path: Path) -> None:
    """lerobot reads the calibration back from the Dynamixel registers (homing offset, limits, drive mode): a
    leader whose reversed elbow is not in its motors is refused before anything is written."""
    with SimulatedDynamixelBus(KOCH_FOLLOWER_MODELS) as follower, SimulatedDynamixelBus(KOCH_LEADER_MODELS) as leader:
        _manifest(project, leader.port)
        opts = HalRecordOptions(
            robot=ROBOT, rskill=None, mode="real", port=follower.port, teleop="leader", out=tmp_path / "a"
        )
        with pytest.raises(HalError, match=r"hardware\.teleop\.calibration_dir: the motors' calibration differs"):
            record_hal(opts)
    assert not (tmp_path / "a").exists()


def test_the_simulated_bus_stuffs_its_replies_like_a_servo() -> None:
    """Register bytes FF FF FD go out stuffed (FF FF FD FD) and dynamixel_sdk's removeStuffing gives the value
    back: without stuffing, FF FF FD FD would read as FF FF FD (the test fails if `stuff` is a no-op)."""
    from lerobot.motors import Motor, MotorNormMode
    from lerobot.motors.dynamixel import DynamixelMotorsBus

    with SimulatedDynamixelBus({1: KOCH_LEADER_MODELS[1]}) as sim:
        bus = DynamixelMotorsBus(sim.port, {"pan": Motor(1, "xl330-m077", MotorNormMode.RANGE_M100_100)})
        bus.connect()
        for raw in (b"\xff\xff\xfd\xfd", b"\xff\xff\xfd\x00"):
            value = int.from_bytes(raw, "little", signed=True)
            sim.servos[1].set("homing", value)
            assert bus.read("Homing_Offset", "pan", normalize=False) == value
        bus.disconnect(disable_torque=False)


def test_without_the_dynamixel_sdk_the_error_names_our_extra(
    project: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import lerobot.robots

    def no_sdk(config: object) -> None:  # what lerobot's DynamixelMotorsBus raises without dynamixel_sdk
        raise ImportError(
            "'dynamixel-sdk' is required but not installed. Install it with: pip install 'lerobot[dynamixel]' "
            "(or uv pip install 'lerobot[dynamixel]')"
        )

    monkeypatch.setattr(lerobot.robots, "make_robot_from_config", no_sdk)
    argv = ["record", "--hal", ROBOT, "--mode", "real", "--teleop", "leader", "--port", "/dev/null"]
    done = run_inproc(*argv, "--out", str(tmp_path / "out"))
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert "hardware.robot.type: koch_follower needs the 'dynamixel' extra" in done.stderr, done.stderr
    assert "pip install 'openral-data[dynamixel]'" in done.stderr and "uv sync --extra dynamixel" in done.stderr
    assert not (tmp_path / "out").exists()
