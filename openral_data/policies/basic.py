"""Trivial policies: `zero` (all-zero actions) and `random` (seeded uniform within the contract bounds)."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from openral_data.schemas.rskill import RSkillManifest
from openral_data.types import Observation


class ZeroPolicy:
    def __init__(self, rskill: RSkillManifest) -> None:
        self._dim = rskill.action_contract.dim

    def reset(self, seed: int) -> None:
        pass

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        return np.zeros(self._dim, dtype=np.float32)

    def close(self) -> None:
        pass


class RandomPolicy:
    """Uniform in [low, high] per dimension (contract bounds, default [-1, 1]); reproducible per episode seed."""

    def __init__(self, rskill: RSkillManifest) -> None:
        c = rskill.action_contract
        self._low = np.asarray(c.low if c.low is not None else [-1.0] * c.dim, dtype=np.float64)
        self._high = np.asarray(c.high if c.high is not None else [1.0] * c.dim, dtype=np.float64)
        self._rng = np.random.default_rng(0)

    def reset(self, seed: int) -> None:
        self._rng = np.random.default_rng(seed)

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        return self._rng.uniform(self._low, self._high).astype(np.float32)

    def close(self) -> None:
        pass
