"""The ROBOTIS OMX pair behind the HAL: lerobot 0.6.1's own OmxFollower (ids 11..16) and OmxLeader (ids 1..6) on
two SIMULATED Dynamixel Protocol 2.0 buses (tests/support/dynamixel_bus.py), recorded through the real CLI with
the shipped `omx_follower` manifest: no OMX code of ours, only the manifest.

The leader is moved by hand (a thread turning its shafts). Every action recorded must be what the leader's bus
reported at that tick, normalised by lerobot with OMX's factory calibration (0..4095: -100..100, the gripper
0..100); the follower's state must follow; lerobot 0.6.1 must load the dataset frame-exact.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from tests.support.dynamixel_bus import (
    OMX_FOLLOWER_MODELS,
    OMX_LEADER_DRIVE_MODES,
    OMX_LEADER_HOMING,
    OMX_LEADER_MODELS,
    OMX_RANGES,
    SimulatedDynamixelBus,
    normalized,
    write_omx_calibration,
)
from tests.support.hal import calibrated_leader_manifest, episode_infos, frames_table
from tests.support.lerobot_written import loaded_episodes
from tests.support.servo_hand import actions_are_reads, record_by_hand

ROBOT = "omx_follower"
LEADER_IDS = range(1, 7)
STEPS = 15


def _manifest(project: Path, leader_port: str) -> Path:
    """The shipped OMX manifest with both arms' factory calibration and the leader on `leader_port`."""
    folder = project / "robots" / ROBOT
    write_omx_calibration(folder / "calibration" / "omx_follower.json", range(11, 17))
    write_omx_calibration(
        folder / "calibration" / "omx_leader.json", LEADER_IDS, OMX_LEADER_DRIVE_MODES, OMX_LEADER_HOMING
    )
    return calibrated_leader_manifest(folder / "robot.yaml", leader_port)


@pytest.mark.slow
def test_the_omx_leader_drives_the_follower_over_two_simulated_dynamixel_buses(project: Path, tmp_path: Path) -> None:
    out = tmp_path / "omx"
    with (
        SimulatedDynamixelBus(OMX_FOLLOWER_MODELS, ranges=OMX_RANGES) as follower,
        SimulatedDynamixelBus(
            OMX_LEADER_MODELS, ranges=OMX_RANGES, drive_modes=OMX_LEADER_DRIVE_MODES, homing=OMX_LEADER_HOMING
        ) as leader,
    ):
        _manifest(project, leader.port)
        r = record_by_hand([leader], ROBOT, out, STEPS, "--port", follower.port)
        assert r.returncode == 0, r.stderr
        reads = list(leader.position_reads)
        released = not any(s.get("torque") for s in [*follower.servos.values(), *leader.servos.values()])
    cols = frames_table(out)
    action, state = np.array(cols["action"]), np.array(cols["observation.state"])
    assert len(action) == STEPS
    # every action is what the leader's bus reported at that tick (one of its reads, in order)
    actions_are_reads(action, [[normalized(r[i], i, OMX_RANGES) for i in LEADER_IDS] for r in reads])
    assert np.ptp(action[:, 1]) > 3.0  # the hand moved the leader
    # the follower's servos follow the previous frame's command (most ticks: a late tick may read them early)
    lag = np.abs(state[1:, :5] - action[:-1, :5])
    assert np.median(lag) < 1.0 and np.mean(lag < 3.0) >= 0.8, lag
    assert released  # lerobot's disconnect released both arms' torque
    info = episode_infos(out)[0]
    assert info["operator"] == "teleop:omx_leader" and info["hal"]["verdict"] == "success"

    loaded = loaded_episodes(out)  # lerobot 0.6.1's own loader: frame-exact
    assert np.array_equal(np.array([f["action"] for f in loaded[0]], dtype=np.float32), action.astype(np.float32))
    assert np.array_equal(np.array([f["state"] for f in loaded[0]], dtype=np.float32), state.astype(np.float32))
