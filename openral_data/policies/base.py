"""The PolicyAdapter protocol every rSkill policy implements."""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from openral_data.types import Observation


@runtime_checkable
class PolicyAdapter(Protocol):
    """reset(seed) before each episode; step(observation, instruction) -> one float32 action; close()."""

    def reset(self, seed: int) -> None: ...

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]: ...

    def close(self) -> None: ...


@runtime_checkable
class ChunkingPolicy(PolicyAdapter, Protocol):
    """A policy that predicts a chunk of future actions from one observation (ACT, diffusion, ...).

    `predict_chunk` returns float32 (k, action_dim): the actions for this step and the k-1 steps after it.
    `n_action_steps` of them are executed before the policy is queried again (`step` does that queueing
    itself in closed loop); offline evaluation compares each executed action with the recorded one.
    """

    n_action_steps: int

    def predict_chunk(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]: ...


@runtime_checkable
class AnnotatingPolicy(PolicyAdapter, Protocol):
    """A policy that says something about the episode it just played (e.g. the generator's source episode and
    segments); `record` stores it in the episode's `openral.episode_info`."""

    def episode_info(self) -> dict[str, Any]: ...
