"""Two SO arms as one robot behind the HAL: lerobot 0.6.1's own BiSOFollower and BiSOLeader (each arm an
unmodified SOFollower / SOLeader, joints prefixed left_/right_) on four SIMULATED Feetech buses at once
(tests/support/feetech_bus.py, one pty per arm), recorded through the real CLI with the shipped `bi_so_follower`
manifest: no bimanual code of ours beyond building lerobot's nested arm configs and checking each arm's
calibration.

Both leaders are moved by hand (a thread per bus). Every action recorded must be what the two leader buses
reported at that tick (left then right), normalised by lerobot; each follower arm's state must follow its own
leader; lerobot 0.6.1 must load the dataset frame-exact.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import ExitStack
from pathlib import Path

import numpy as np
import pytest
import yaml

from openral_data.errors import ConfigError
from openral_data.record.hal import HalRecordOptions, record_hal
from tests.support.feetech_bus import ADDR, SimulatedFeetechBus, so_normalized, write_so_calibration
from tests.support.hal import episode_infos, frames_table
from tests.support.lerobot_written import loaded_episodes
from tests.support.servo_hand import actions_are_reads, record_by_hand

ROBOT = "bi_so_follower"
IDS = list(range(1, 7))
STEPS = 15
Buses = dict[str, SimulatedFeetechBus]  # "follower_left", "follower_right", "leader_left", "leader_right"


def _manifest(project: Path, buses: Buses, *, calibrated: tuple[str, ...] = ("left", "right")) -> Path:
    """The shipped manifest on `buses`, with the `calibrated` arms' calibration files (follower and leader)."""
    folder = project / "robots" / ROBOT
    path = folder / "robot.yaml"
    manifest = yaml.safe_load(path.read_text())
    for role, field in (("follower", "robot"), ("leader", "teleop")):
        device = manifest["hardware"][field]
        device["calibration_dir"] = "calibration"
        for side in ("left", "right"):
            device[f"{side}_arm_config"]["port"] = buses[f"{role}_{side}"].port
        for side in calibrated:
            write_so_calibration(folder / "calibration" / f"{device['id']}_{side}.json")
    path.write_text(yaml.safe_dump(manifest, sort_keys=False))
    return path


@pytest.fixture
def buses() -> Iterator[Buses]:
    with ExitStack() as stack:
        yield {
            f"{role}_{side}": stack.enter_context(SimulatedFeetechBus(IDS))
            for role in ("follower", "leader")
            for side in ("left", "right")
        }


@pytest.mark.slow
def test_two_so_leaders_drive_two_followers_as_one_robot(project: Path, tmp_path: Path, buses: Buses) -> None:
    _manifest(project, buses)
    out = tmp_path / "bi"
    r = record_by_hand([buses["leader_left"], buses["leader_right"]], ROBOT, out, STEPS)
    assert r.returncode == 0, r.stderr
    cols = frames_table(out)
    action, state = np.array(cols["action"]), np.array(cols["observation.state"])
    assert action.shape == state.shape == (STEPS, 12)
    # each half of every action is what that leader's bus reported at that tick (one of its reads, in order)
    for half, side in ((slice(0, 6), "left"), (slice(6, 12), "right")):
        reads = [[so_normalized(r[i], i) for i in IDS] for r in buses[f"leader_{side}"].position_reads]
        actions_are_reads(action[:, half], reads)
    # the hand's two threads move the arms differently (their phases differ per servo id, not per arm: equal
    # is possible only by chance), and each follower arm follows its own leader (most ticks)
    assert np.ptp(action[:, 0]) > 3.0 and np.ptp(action[:, 6]) > 3.0
    arms = [*range(0, 5), *range(6, 11)]
    lag = np.abs(state[1:, arms] - action[:-1, arms])
    assert np.median(lag) < 1.0 and np.mean(lag < 3.0) >= 0.8, lag
    assert not any(s.regs[ADDR["torque"]] for bus in buses.values() for s in bus.servos.values())  # released
    info = episode_infos(out)[0]
    assert info["operator"] == "teleop:bi_so_leader" and info["hal"]["verdict"] == "success"

    loaded = loaded_episodes(out)  # lerobot 0.6.1's own loader: frame-exact
    assert np.array_equal(np.array([f["action"] for f in loaded[0]], dtype=np.float32), action.astype(np.float32))
    assert np.array_equal(np.array([f["state"] for f in loaded[0]], dtype=np.float32), state.astype(np.float32))


def test_a_bimanual_arm_without_its_calibration_file_is_one_line(project: Path, tmp_path: Path, buses: Buses) -> None:
    """lerobot's bimanual robot has no bus of its own: each arm's calibration file is still required (else
    lerobot would connect an uncalibrated arm), and the line names the missing file."""
    _manifest(project, buses, calibrated=("left",))
    opts = HalRecordOptions(robot=ROBOT, rskill=None, mode="real", port=None, teleop="leader", out=tmp_path / "a")
    with pytest.raises(ConfigError, match=r"hardware\.robot\.calibration_dir: no calibration .*bi_so_follower_right"):
        record_hal(opts)
    assert not (tmp_path / "a").exists()
