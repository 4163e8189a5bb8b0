"""`--mode policy`: offline evaluation. Each recorded observation (decoded camera frames, state, task) goes to
the policy and its action is compared with the recorded one. No simulator: works on any LeRobot v3 dataset
with `observation.state` and `action`, including datasets converted from hardware bags.

Chunk-aware: a `ChunkingPolicy` is queried at the first frame and again whenever the actions it may execute
(`n_action_steps` of its chunk) are used up; each executed action is compared with the recorded action of
the frame it covers. Other policies are asked once per frame.
"""

from __future__ import annotations

from collections import deque
from typing import Any, Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from openral_data.errors import ContractViolation
from openral_data.policies.base import ChunkingPolicy, PolicyAdapter
from openral_data.replay.outcome import EpisodeOutcome
from openral_data.replay.recorded import RecordedDataset, RecordedEpisode
from openral_data.types import Observation


@runtime_checkable
class EpisodeAware(Protocol):
    """A policy that wants the recorded episode before its first frame (the `recorded` reference policy)."""

    def begin_episode(self, episode: RecordedEpisode) -> None: ...


def checked_action(action: Any, dim: int, where: str) -> npt.NDArray[np.float32]:
    arr = np.asarray(action)
    if arr.dtype != np.float32 or arr.shape != (dim,) or not np.isfinite(arr).all():
        raise ContractViolation(
            f"{where}: policy action: expected finite float32[{dim}], got {arr.dtype}{list(arr.shape)}"
            + ("" if np.isfinite(arr).all() else " with non-finite values")
        )
    return arr


def evaluate_episode(dataset: RecordedDataset, e: int, policy: PolicyAdapter) -> EpisodeOutcome:
    episode = dataset.episode(e)
    n, dim = episode.actions.shape
    predicted = np.empty((n, dim), dtype=np.float64)
    policy.reset(episode.seed or 0)
    if isinstance(policy, EpisodeAware):
        policy.begin_episode(episode)
    chunking = isinstance(policy, ChunkingPolicy)
    queue: deque[npt.NDArray[np.float32]] = deque()
    for t, frame in enumerate(dataset.frames(e)):
        where = f"episode {e} frame {t}"
        obs = Observation(images=frame.images, state=frame.state, task=frame.task, time=frame.timestamp)
        if not chunking:
            predicted[t] = checked_action(policy.step(obs, obs.task), dim, where)
            continue
        if not queue:
            chunk = np.asarray(policy.predict_chunk(obs, obs.task))  # type: ignore[attr-defined]
            if chunk.ndim != 2 or len(chunk) == 0:
                raise ContractViolation(f"{where}: policy chunk: expected (k, {dim}), got shape {list(chunk.shape)}")
            steps = max(1, int(policy.n_action_steps))  # type: ignore[attr-defined]
            queue.extend(checked_action(a, dim, where) for a in chunk[:steps])
        predicted[t] = queue.popleft()
    return EpisodeOutcome(
        index=e,
        steps=n,
        success_recorded=episode.success,
        success_replayed=None,  # offline: the policy's actions are never executed
        frames=np.arange(n, dtype=np.int64),
        action_abs=np.abs(predicted - episode.actions.astype(np.float64)),
    )
