"""A test policy that remembers the instruction it is given at each step (and acts with zeros)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from openral_data.policies.base import PolicyAdapter
from openral_data.schemas.rskill import RSkillManifest
from openral_data.types import Observation


def listening(seen: list[str]) -> Callable[[RSkillManifest], PolicyAdapter]:
    """A policy factory whose policies append every instruction they are given to `seen`."""

    class Listener:
        def __init__(self, rskill: RSkillManifest) -> None:
            self.dim = rskill.action_contract.dim

        def reset(self, seed: int) -> None:
            pass

        def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
            seen.append(instruction)
            return np.zeros(self.dim, dtype=np.float32)

        def close(self) -> None:
            pass

    return Listener
