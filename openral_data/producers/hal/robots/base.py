"""The HAL protocol: a robot behind connect / read_state / send_action / estop, with typed state and actions.

Every HAL shares `HalBase`, which owns the rules that must not differ between a twin and real hardware:
connect/disconnect are idempotent; `read_state` raises `StaleState` when the reading is older than the
manifest's `safety.max_state_age`; `estop()` latches, and until `reset_estop()` every `send_action` raises
`EstopLatched` (nothing reaches the robot). Times are `time.monotonic()` seconds.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
import numpy.typing as npt

from openral_data.errors import EstopLatched, HalError, StaleState
from openral_data.producers.hal.cameras.sensors import CameraSensor
from openral_data.producers.hal.robots.safety import ForwardKinematics
from openral_data.schemas.robot import RobotManifest
from openral_data.types import Privileged

F32 = npt.NDArray[np.float32]


@dataclass(frozen=True)
class RobotState:
    """Joint positions in the manifest's `observation.state` order, sampled at `stamp` (monotonic s)."""

    positions: F32
    stamp: float

    def age(self, now: float) -> float:
        return now - self.stamp


@dataclass(frozen=True)
class JointCommand:
    """Joint position targets in the manifest's `action` order (gripper normalised as the manifest says)."""

    positions: F32


def monotonic() -> float:
    return time.monotonic()


class Outcome(NamedTuple):
    """What a HAL that runs a task (a sim scene) knows after the last command."""

    reward: float
    success: bool
    terminated: bool


class HalBase(ABC):
    """Connection, staleness and e-stop rules; subclasses implement the `_`-methods for one robot."""

    def __init__(self, robot: RobotManifest) -> None:
        self.robot = robot
        self.cameras: dict[str, CameraSensor] = {}
        self.max_state_age = robot.safety.max_state_age
        self._connected = False
        self._estop_reason: str | None = None
        self.last_command: JointCommand | None = None

    # -- subclass hooks --------------------------------------------------------------------------------------
    @abstractmethod
    def _connect(self) -> None: ...

    @abstractmethod
    def _disconnect(self) -> None: ...

    @abstractmethod
    def _read_state(self) -> RobotState: ...

    @abstractmethod
    def _send(self, command: JointCommand) -> JointCommand: ...

    def _hold(self) -> None:
        """Stop moving (called once when the e-stop latches). Default: command the current position."""
        state = self._read_state()
        self._send(JointCommand(state.positions[: self.action_dim].copy()))

    # -- optional per-HAL information (defaults for hardware) ------------------------------------------------
    @property
    def state_dim(self) -> int:
        return self.robot.observation.state.dim

    @property
    def action_dim(self) -> int:
        return self.robot.action.dim

    def begin_episode(self, seed: int) -> dict[str, Any]:
        """Called before each episode; returns JSON-able data describing the starting state."""
        return {"robot": self.robot.name}

    def privileged(self) -> Privileged:
        """Ground truth a simulator knows (scripted experts read it); hardware has none."""
        return {}

    def outcome(self) -> Outcome | None:
        """Reward, success and termination after the last command, when the HAL knows them (a sim scene)."""
        return None

    @property
    def environment_state_names(self) -> tuple[str, ...]:
        """The names of `environment_state()`'s dimensions (lerobot's `observation.environment_state`: a sim
        scene's object poses, `scene.observations.environment_state`); empty: the HAL has none (hardware)."""
        return ()

    def environment_state(self) -> F32 | None:
        """The environment state now, one value per `environment_state_names` entry; None when it has none."""
        return None

    @property
    def has_reward(self) -> bool:
        """Whether `outcome()` reports reward and success (the dataset then stores them)."""
        return False

    @property
    def task(self) -> str | None:
        """The language instruction of the HAL's own task (a sim scene's); None: the rSkill's description."""
        return None

    @property
    def state_names(self) -> list[str] | None:
        """Names of `read_state`'s dimensions when they are not the manifest's `observation.state` ones."""
        return None

    @property
    def action_names(self) -> list[str] | None:
        """Names of `send_action`'s dimensions when they are not the manifest's `action` ones."""
        return None

    def kinematics(self) -> ForwardKinematics | None:
        """Forward kinematics for the safety filter's workspace check, when the HAL has a model of the robot."""
        return None

    def close(self) -> None:
        """Disconnect and release what the HAL holds beyond the connection (a sim scene)."""
        self.disconnect()

    # -- the protocol ----------------------------------------------------------------------------------------
    @property
    def connected(self) -> bool:
        return self._connected

    @property
    def estopped(self) -> bool:
        return self._estop_reason is not None

    @property
    def estop_reason(self) -> str | None:
        return self._estop_reason

    def connect(self) -> None:
        if self._connected:
            return
        self._connect()
        self._connected = True
        for cam in self.cameras.values():
            cam.start()

    def disconnect(self) -> None:
        if not self._connected:
            return
        try:
            for cam in self.cameras.values():
                cam.stop()
        finally:
            self._connected = False
            self._disconnect()

    def _require_connected(self, what: str) -> None:
        if not self._connected:
            raise HalError(
                f"robot {self.robot.name}: {what}: not connected (call connect() first)", code="hal.disconnected"
            )

    def read_state(self) -> RobotState:
        self._require_connected("read_state")
        state = self._read_state()
        dim = self.state_dim
        if state.positions.shape != (dim,) or state.positions.dtype != np.float32:
            raise HalError(
                f"robot {self.robot.name}: read_state: expected float32[{dim}], got {state.positions.shape}",
                code="hal.state",
            )
        age = state.age(monotonic())
        if age > self.max_state_age:
            raise StaleState(
                f"robot {self.robot.name}: joint state is {age * 1000:.0f} ms old "
                f"(limit {self.max_state_age * 1000:.0f} ms, safety.max_state_age)"
            )
        return state

    def send_action(self, command: JointCommand) -> JointCommand:
        """Send joint targets; returns what was actually sent. Raises EstopLatched while the e-stop is latched."""
        self._require_connected("send_action")
        if self._estop_reason is not None:
            raise EstopLatched(
                f"robot {self.robot.name}: e-stop latched ({self._estop_reason}); action refused until reset_estop()"
            )
        dim = self.action_dim
        pos = command.positions
        if pos.shape != (dim,) or not np.isfinite(pos).all():
            raise HalError(
                f"robot {self.robot.name}: send_action: expected finite float32[{dim}], got {pos}", code="hal.command"
            )
        sent = self._send(JointCommand(pos.astype(np.float32, copy=True)))
        self.last_command = sent
        return sent

    def estop(self, reason: str) -> None:
        """Latch the e-stop and hold position. Idempotent: the first reason is kept."""
        if self._estop_reason is not None:
            return
        self._estop_reason = reason or "e-stop"
        if self._connected:
            self._hold()

    def reset_estop(self) -> None:
        self._estop_reason = None

    def __enter__(self) -> HalBase:
        self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.disconnect()
