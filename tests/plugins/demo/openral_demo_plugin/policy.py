"""`p_control`: a PD controller driving the slider's position (state[0]) to `policy_extras.target`."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from openral_data import POLICIES
from openral_data.schemas.rskill import RSkillManifest
from openral_data.types import Observation


@POLICIES.register("p_control")
class PController:
    def __init__(self, rskill: RSkillManifest) -> None:
        self.target = float(rskill.policy_extras.get("target", 0.5))  # type: ignore[arg-type]
        self.kp, self.kd = 20.0, 9.0

    def reset(self, seed: int) -> None:
        pass

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        x, v = float(observation.state[0]), float(observation.state[1])
        return np.array([self.kp * (self.target - x) - self.kd * v], dtype=np.float32)

    def close(self) -> None:
        pass
