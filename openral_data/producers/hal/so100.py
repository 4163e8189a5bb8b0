"""The SO-100 / SO-101 follower arm through lerobot 0.6.1's own driver (`lerobot[feetech]`: the Feetech
STS3215 bus via the scservo SDK), configured from the manifest's `hardware:` block.

The driver is used as lerobot users know it: `SOFollower(SOFollowerRobotConfig(port, id, calibration_dir))`,
`get_observation()` / `send_action()` with `<motor>.pos` keys. Differences, all for unattended recording:
connect never starts lerobot's interactive calibration — the calibration file (`<calibration_dir>/<id>.json`,
written by `lerobot-calibrate`) must exist and match the motors, else connecting fails with a one-line error.
The joint state is stamped with the monotonic clock at the midpoint of the bus read.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from openral_data.errors import ConfigError, HalError, install_hint
from openral_data.producers.hal.base import HalBase, JointCommand, RobotState, monotonic
from openral_data.schemas.hal import HardwareConfig
from openral_data.schemas.robot import RobotManifest

MOTORS = ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll", "gripper")


def _names(robot: RobotManifest, source: str) -> list[str]:
    state = robot.observation.state.names
    action = robot.action.names
    if state != action or state is None or sorted(state) != sorted(MOTORS):
        raise ConfigError(
            f"{source}: observation.state.names / action.names: the SO follower needs both to name its motors "
            f"{list(MOTORS)} (any order, the same in both)"
        )
    return list(state)


class So100Hal(HalBase):
    """SO-100 / SO-101 follower (same driver; the manifest's `hardware.driver` names the model)."""

    def __init__(self, robot: RobotManifest, hardware: HardwareConfig, source: str) -> None:
        super().__init__(robot)
        self.names = _names(robot, source)
        self.source = source
        try:
            from lerobot.robots.so_follower import SOFollower, SOFollowerRobotConfig
        except ImportError:  # lerobot's SO follower driver and the scservo SDK come with the feetech extra
            raise ConfigError(
                f"{source}: hardware.driver: {hardware.driver} needs the 'feetech' extra (lerobot's Feetech "
                f"driver): {install_hint('feetech')}"
            ) from None
        cal_dir = None
        if hardware.calibration_dir is not None:
            cal_dir = Path(hardware.calibration_dir).expanduser()
            if not cal_dir.is_absolute():
                cal_dir = Path(source).parent / cal_dir
        config = SOFollowerRobotConfig(
            port=hardware.port,
            id=hardware.id,
            calibration_dir=cal_dir,
            max_relative_target=hardware.max_relative_target,
            use_degrees=hardware.use_degrees,
        )
        self.driver: Any = SOFollower(config)
        self.hardware = hardware

    def _connect(self) -> None:
        path = Path(self.driver.calibration_fpath)
        if not path.is_file():
            raise ConfigError(
                f"{self.source}: hardware.calibration_dir: no calibration {path} "
                f"(run: lerobot-calibrate --robot.type=so100_follower --robot.port=... --robot.id={self.hardware.id})"
            )
        try:
            self.driver.connect(calibrate=False)
        except (OSError, ConnectionError, RuntimeError) as exc:
            raise HalError(
                f"{self.source}: hardware.port: cannot connect to {self.hardware.port}: {exc}", code="hal.connect"
            ) from None
        if not self.driver.is_calibrated:
            self.driver.disconnect()
            raise HalError(
                f"{self.source}: hardware.calibration_dir: the motors' calibration differs from {path} "
                "(recalibrate with lerobot-calibrate, or point calibration_dir at this arm's file)",
                code="hal.calibration",
            )

    def _disconnect(self) -> None:
        if self.driver.is_connected:
            self.driver.disconnect()

    def _read_state(self) -> RobotState:
        before = monotonic()
        obs = self.driver.get_observation()
        stamp = (before + monotonic()) / 2
        return RobotState(np.array([obs[f"{n}.pos"] for n in self.names], dtype=np.float32), stamp)

    def _send(self, command: JointCommand) -> JointCommand:
        goal = {f"{n}.pos": float(v) for n, v in zip(self.names, command.positions, strict=True)}
        sent = self.driver.send_action(goal)
        return JointCommand(np.array([sent[f"{n}.pos"] for n in self.names], dtype=np.float32))

    def begin_episode(self, seed: int) -> dict[str, Any]:
        return {"hal": self.hardware.driver, "robot": self.robot.name, "port": self.hardware.port}


def make_hardware_hal(robot: RobotManifest, source: str, port: str | None = None) -> HalBase:
    if robot.hardware is None:
        raise ConfigError(f"{source}: hardware: robot {robot.name!r} has no hardware block (--mode real needs one)")
    hardware = robot.hardware if port is None else robot.hardware.model_copy(update={"port": port})
    return So100Hal(robot, hardware, source)
