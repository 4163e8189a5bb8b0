"""`sweep`: smooth joint-space motion around where the first episode started — a policy for exercising a HAL.

Later episodes sweep around the same posture (no drift from episode to episode); the HAL's velocity limit
brings the arm back to it smoothly.

Action (joint targets, the rSkill's action order = state order for the first `action dim` entries):
`start + amplitude * sin(2π t / period)` per arm joint (alternating sign), the last dimension (gripper)
from `gripper_low` to `gripper_high` and back (`0.5 - 0.5 cos(2π t / period)` of the span). `t` is the
observation's clock (the HAL's monotonic time) when it has one. `policy_extras`: `amplitude` (joint units,
default 0.2), `period` (seconds, default 4), `fps` (clock fallback, 20), `gripper_low` / `gripper_high` (0, 1).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from openral_data.errors import ConfigError
from openral_data.schemas.rskill import RSkillManifest
from openral_data.types import Observation


class SweepPolicy:
    def __init__(self, rskill: RSkillManifest) -> None:
        extras = rskill.policy_extras
        values = []
        defaults = (("amplitude", 0.2), ("period", 4.0), ("fps", 20.0), ("gripper_low", 0.0), ("gripper_high", 1.0))
        for key, default in defaults:
            value = extras.get(key, default)
            if not isinstance(value, int | float) or isinstance(value, bool):
                raise ConfigError(f"rskill {rskill.id}: policy_extras.{key}: expected a number, got {value!r}")
            values.append(float(value))
        self.amplitude, self.period, self.fps, self.gripper_low, self.gripper_high = values
        if self.period <= 0 or self.fps <= 0:
            raise ConfigError(f"rskill {rskill.id}: policy_extras: period and fps must be > 0")
        self.dim = rskill.action_contract.dim
        self._start: npt.NDArray[np.float64] | None = None
        self._step = 0

    def reset(self, seed: int) -> None:
        self._step = 0

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        state = np.asarray(observation.state, dtype=np.float64)
        if self._start is None:
            self._start = state[: self.dim].copy()
        t = observation.time if observation.time is not None else self._step / self.fps
        self._step += 1
        phase = 2 * math.pi * t / self.period
        signs = np.where(np.arange(self.dim - 1) % 2 == 0, 1.0, -1.0)
        action = self._start.copy()
        action[:-1] += self.amplitude * signs * math.sin(phase)
        action[-1] = self.gripper_low + (self.gripper_high - self.gripper_low) * (0.5 - 0.5 * math.cos(phase))
        return action.astype(np.float32)

    def close(self) -> None:
        pass
