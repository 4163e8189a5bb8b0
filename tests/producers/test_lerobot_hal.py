"""lerobot's hardware classes behind the HAL: an SO-101 leader arm drives the follower, both lerobot's own
classes (`make_robot_from_config`, `make_teleoperator_from_config`) on two SIMULATED Feetech buses at once
(tests/support/feetech_bus.py, one pty each), and the same leader drives the follower's MuJoCo twin.

The leader is moved by hand in the test: a thread turns its servos' positions (torque off, as lerobot's leader
leaves it). Every action recorded must be what the leader's bus reported at that tick, converted by lerobot's
calibration; the follower's state must follow; lerobot 0.6.1 must load the dataset frame-exact.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml

from openral_data.errors import ConfigError, HalError
from openral_data.record.hal import HalRecordOptions, record_hal
from tests.support.feetech_bus import SimulatedFeetechBus, calibrated_so_project, write_so_calibration
from tests.support.hal import episode_infos, frames_table
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import loaded_episodes
from tests.support.servo_hand import Hand, actions_are_reads

ROBOT = "so101_follower"
IDS = list(range(1, 7))
STEPS = 15


def _manifest(project: Path, leader_port: str, **teleop: Any) -> Path:
    """The SO-101 manifest with calibration files for both arms and the leader on `leader_port`."""
    folder = project / "robots" / ROBOT
    write_so_calibration(folder / "calibration" / f"{ROBOT}.json")
    write_so_calibration(folder / "calibration" / "so101_leader.json")
    path = folder / "robot.yaml"
    manifest = yaml.safe_load(path.read_text())
    manifest["hardware"]["calibration_dir"] = "calibration"
    manifest["hardware"]["teleop"].update({"port": leader_port, "calibration_dir": "calibration", **teleop})
    path.write_text(yaml.safe_dump(manifest, sort_keys=False))
    return path


def degrees(raw: int) -> float:
    """lerobot's DEGREES normalisation for a range 1024..3072 (STS3215: 4096 steps)."""
    return (raw - 2048) * 360 / 4095


def percent(raw: int) -> float:
    """lerobot's RANGE_0_100 normalisation (the gripper) for a range 1024..3072."""
    return (raw - 1024) / (3072 - 1024) * 100


def _recorded(out: Path) -> tuple[np.ndarray, np.ndarray]:
    cols = frames_table(out)
    return np.array(cols["action"]), np.array(cols["observation.state"])


@pytest.fixture
def buses(project: Path) -> Iterator[tuple[SimulatedFeetechBus, SimulatedFeetechBus]]:
    """The follower's and the leader's bus, the manifest pointing at the leader's."""
    with SimulatedFeetechBus(IDS) as follower, SimulatedFeetechBus(IDS) as leader:
        _manifest(project, leader.port)
        yield follower, leader


@pytest.mark.slow
def test_leader_drives_the_follower_over_two_simulated_buses(
    tmp_path: Path, buses: tuple[SimulatedFeetechBus, SimulatedFeetechBus]
) -> None:
    follower, leader = buses
    out = tmp_path / "leader"
    opts = HalRecordOptions(
        robot=ROBOT, rskill=None, mode="real", port=follower.port, teleop="leader", fps=10, max_steps=STEPS,
        out=out, codec="h264", operator="success",
    )  # fmt: skip
    with Hand(leader):
        s = record_hal(opts)
    assert s.episodes[0].length == STEPS and s.all_reports[0].accounted()
    action, state = _recorded(out)
    # every action is what the leader's bus reported at that tick (one of its reads, in order)
    actions_are_reads(action, [[degrees(r[i]) for i in IDS[:5]] + [percent(r[6])] for r in leader.position_reads])
    assert np.ptp(action[:, 0]) > 3.0  # the hand moved the leader
    # the follower's servos follow: readings close to the previous frame's command (a tick the loaded machine
    # started late may read the servos before they arrived: most, not all)
    lag = np.abs(state[1:, :5] - action[:-1, :5])
    assert np.median(lag) < 1.0 and np.mean(lag < 3.0) >= 0.8, lag
    assert np.abs(state[1:] - state[:-1]).max() > 0.5
    info = episode_infos(out)[0]
    assert info["operator"] == "teleop:so101_leader" and info["hal"]["verdict"] == "success"

    sql = "SELECT operator FROM episodes"  # who drove, queryable
    r = run_inproc("stats", str(out), "--sql", sql, "--format", "json")
    assert r.returncode == 0 and json.loads(r.stdout)["sql"] == [{"operator": "teleop:so101_leader"}], r.stdout

    loaded = loaded_episodes(out)  # lerobot 0.6.1's own loader: frame-exact
    assert np.array_equal(np.array([f["action"] for f in loaded[0]], dtype=np.float32), action.astype(np.float32))
    assert np.array_equal(np.array([f["state"] for f in loaded[0]], dtype=np.float32), state.astype(np.float32))


@pytest.mark.slow
def test_the_leader_drives_the_twin_in_sim_mode(tmp_path: Path, buses: tuple[SimulatedFeetechBus, ...]) -> None:
    """`--mode sim --teleop leader`: practice on the MuJoCo twin with the real leader (no follower)."""
    leader = buses[1]
    out = tmp_path / "twin"
    with Hand(leader):
        r = run_inproc(
            "record", "--hal", ROBOT, "--teleop", "leader", "--fps", "10", "--max-steps", str(STEPS),
            "--out", str(out), "--codec", "h264", "--operator", "success",
        )  # fmt: skip
    assert r.returncode == 0, r.stderr
    action, state = _recorded(out)
    actions_are_reads(action[:, :5], [[degrees(x[i]) for i in IDS[:5]] for x in leader.position_reads])
    lag = np.abs(state[1:, :5] - action[:-1, :5])  # the twin's servos follow the leader (with the model's lag)
    assert lag.mean() < 2.0 and lag.max() < 10.0, lag
    assert np.ptp(state[:, 0]) > 3.0
    assert episode_infos(out)[0]["operator"] == "teleop:so101_leader"


def test_leader_failures_are_one_line_before_anything_is_written(
    project: Path, tmp_path: Path, buses: tuple[SimulatedFeetechBus, SimulatedFeetechBus]
) -> None:
    follower, leader = buses
    path = _manifest(project, "/dev/openral-no-such-port")
    opts = dict(robot=ROBOT, rskill=None, mode="real", port=follower.port, teleop="leader", out=tmp_path / "a")
    with pytest.raises(HalError, match=r"robot\.yaml: hardware\.teleop\.port: cannot connect to /dev/openral-no"):
        record_hal(HalRecordOptions(**opts))  # type: ignore[arg-type]
    (path.parent / "calibration" / "so101_leader.json").unlink()
    with pytest.raises(ConfigError, match=r"hardware\.teleop\.calibration_dir: no calibration .*lerobot-calibrate"):
        record_hal(HalRecordOptions(**opts))  # type: ignore[arg-type]
    _manifest(project, leader.port, type="no_such_leader")
    with pytest.raises(ConfigError, match=r"hardware\.teleop\.type: 'no_such_leader' is not a lerobot teleoperators"):
        record_hal(HalRecordOptions(**opts))  # type: ignore[arg-type]
    b = tmp_path / "b"  # an unplugged follower (no such port), through the CLI: one line, exit 2
    r = run_inproc(
        "record",
        "--hal",
        ROBOT,
        "--mode",
        "real",
        "--rskill",
        "sweep-so-arm",
        "--port",
        "/dev/openral-x",
        "--out",
        str(b),
    )
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "hardware.port: cannot connect" in r.stderr, r.stderr
    assert not (tmp_path / "a").exists() and not b.exists()


@pytest.mark.parametrize("robot", ["so100_follower", "so101_follower", "koch_follower"])
def test_every_shipped_hardware_manifest_builds_lerobots_configs(robot: str) -> None:
    """Each shipped manifest's robot and teleoperator are lerobot configs lerobot itself accepts (the Koch pair
    records on simulated Dynamixel buses in test_koch_hal.py)."""
    from openral_data.producers.hal.robots.lerobot_hw import lerobot_config
    from openral_data.producers.hal.robots.lerobot_hw import registry as lerobot_types
    from openral_data.runtime import registry

    hardware = registry.ROBOTS[robot].hardware
    assert hardware is not None and hardware.teleop is not None
    follower = lerobot_config("robots", hardware.robot_config(), "robot.yaml", "hardware")
    leader = lerobot_config("teleoperators", hardware.teleop, "robot.yaml", "hardware.teleop")
    # (lerobot registers so100_/so101_ names for one SO config class: compare classes, not `.type`)
    assert type(follower) is lerobot_types("robots").get_choice_class(hardware.robot_config()["type"])
    assert type(leader) is lerobot_types("teleoperators").get_choice_class(hardware.teleop["type"])


def test_a_bus_read_waits_for_the_reply_instead_of_polling_for_it(
    project: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The servo SDK polls a non-blocking port in a Python loop while a reply is on its way (a core spinning on the
    control thread, the GIL taken back at every poll); connected through the HAL, a read sleeps until the bytes
    are there. The bus here takes 20 ms to answer, as a USB adapter's latency timer can."""
    from scservo_sdk.port_handler import PortHandler

    from openral_data.producers.hal.robots.lerobot_hw import make_hardware_hal
    from openral_data.runtime import registry

    polls = 0
    read_port = PortHandler.readPort

    def counted(self: PortHandler, length: int) -> bytes:
        nonlocal polls
        polls += 1
        return bytes(read_port(self, length))

    calibrated_so_project(project, ROBOT)
    source = project / "robots" / ROBOT / "robot.yaml"
    with SimulatedFeetechBus(IDS) as bus, make_hardware_hal(registry.load_robot(ROBOT), str(source), bus.port) as hal:
        bus.reply_delay_s = 0.02
        monkeypatch.setattr(PortHandler, "readPort", counted)
        states = [hal.read_state().positions for _ in range(3)]
    # the calibrated middle, the gripper half open: the replies were read whole
    assert np.allclose(states, [[0, 0, 0, 0, 0, 50]] * 3, atol=0.2)
    assert polls <= 3 * 6 * 8, polls  # 3 reads of 6 servos' replies, a few polls each (polling: thousands)
