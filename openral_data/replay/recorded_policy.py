"""`--rskill recorded[:K]`: a policy that returns the dataset's own recorded actions.

It is the zero-error reference of `--mode policy` (any non-zero error is a bug in decoding, alignment or
chunk bookkeeping, not in a model). With `:K` it emits chunks of K recorded actions and executes them all,
which exercises the chunk-aware path.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from openral_data.errors import ReplayError, UsageError
from openral_data.replay.recorded import RecordedEpisode
from openral_data.types import Observation

PREFIX = "recorded"


def parse(ref: str) -> int | None:
    """`recorded` -> 1, `recorded:K` -> K, anything else -> None (an ordinary rSkill reference)."""
    name, _, chunk = ref.partition(":")
    if name != PREFIX:
        return None
    try:
        k = int(chunk) if chunk else 1
    except ValueError:
        raise UsageError(f"--rskill {ref}: expected recorded or recorded:K with K a whole number") from None
    if k < 1:
        raise UsageError(f"--rskill {ref}: K must be >= 1")
    return k


class RecordedActions:
    """PolicyAdapter (+ ChunkingPolicy when K > 1) returning episode `begin_episode(...)`'s actions in order."""

    def __init__(self, chunk: int = 1) -> None:
        self.n_action_steps = chunk
        self._actions: npt.NDArray[np.float32] = np.zeros((0, 0), dtype=np.float32)
        self._t = 0

    def begin_episode(self, episode: RecordedEpisode) -> None:
        self._actions = episode.actions
        self._t = 0

    def reset(self, seed: int) -> None:
        self._t = 0

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        action: npt.NDArray[np.float32] = self._next(1)[0]
        return action

    def predict_chunk(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        return self._next(self.n_action_steps)

    def _next(self, k: int) -> npt.NDArray[np.float32]:
        chunk = self._actions[self._t : self._t + k]
        if not len(chunk):
            raise ReplayError(f"recorded policy: asked for an action after the episode's {len(self._actions)}")
        self._t += len(chunk)
        return np.array(chunk, dtype=np.float32)

    def close(self) -> None:
        pass
