"""A lerobot teleoperator (a leader arm: SO-100/101, Koch, OMX, OpenArm, ...) as the producer of actions.

`LeaderTeleop` is a policy (reset / step / close): each tick it reads the device's `get_action()` (lerobot's
own class, built from the manifest's `hardware.teleop` by `make_teleoperator_from_config`) and returns the
values of the manifest's action names (`<name>.pos` keys), so the leader's positions go through the same
contract check, safety filter and HAL as an rSkill's actions: to the real follower (`--mode real`) or to the
robot's MuJoCo twin (`--mode sim`, practice without a follower). The leader is connected before anything is
recorded, with the same calibration rules as the robot (producers/hal/robots/lerobot_hw.py).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from openral_data.errors import ConfigError
from openral_data.producers.hal.robots.base import monotonic
from openral_data.producers.hal.robots.lerobot_hw import connect_device, feature_keys, lerobot_config, missing_sdk
from openral_data.schemas.robot import RobotManifest
from openral_data.types import Observation

FIELD = "hardware.teleop"


class LeaderTeleop:
    """The manifest's `hardware.teleop` device; `step()` returns its positions in the manifest's action order."""

    def __init__(self, robot: RobotManifest, source: str, port: str | None = None) -> None:
        spec = robot.hardware.teleop if robot.hardware is not None else None
        if spec is None:
            raise ConfigError(f"{source}: {FIELD}: robot {robot.name!r} names no teleoperator (--teleop leader)")
        spec = {**spec, **({"port": port} if port is not None else {})}
        self.source = source
        self.type_name = str(spec["type"])
        config = lerobot_config("teleoperators", spec, source, FIELD)
        try:
            from lerobot.teleoperators import make_teleoperator_from_config

            self.device: Any = make_teleoperator_from_config(config)
        except ImportError as exc:
            raise ConfigError(f"{source}: {FIELD}.type: {self.type_name} {missing_sdk(exc)}") from None
        self.keys = feature_keys(robot.action.names or [], self.device.action_features, source, FIELD)
        self.read_at = 0.0  # monotonic time of the last reading

    def connect(self) -> None:
        if not self.device.is_connected:
            connect_device(self.device, self.source, FIELD, self.type_name)

    def reset(self, seed: int) -> None:
        self.connect()

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        action = self.device.get_action()
        self.read_at = monotonic()
        return np.array([action[k] for k in self.keys], dtype=np.float32)

    def close(self) -> None:
        if self.device.is_connected:
            self.device.disconnect()
