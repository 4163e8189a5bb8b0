"""The PolicyAdapter protocol every rSkill policy implements."""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from openral_data.producers.base import Observation


@runtime_checkable
class PolicyAdapter(Protocol):
    """reset(seed) before each episode; step(observation, instruction) -> one float32 action; close()."""

    def reset(self, seed: int) -> None: ...

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]: ...

    def close(self) -> None: ...
