"""`--mode actions`: restore each episode's recorded initial state, feed the recorded actions step by step and
compare the states the scene produces with the recorded ones.

Frame t of the comparison is the observation after the t actions 0..t-1 (frame 0 checks the restore itself).
The replay stops where the recording stopped: after the last recorded action, or earlier when the scene
reports termination (the recorder ends an episode there too). The replayed success is the scene's success at
that point, exactly as `record` decides it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from openral_data.errors import ReplayError
from openral_data.replay.outcome import EpisodeOutcome, first_exceeding, object_error
from openral_data.replay.recorded import RecordedEpisode
from openral_data.types import Observation, SimRollout, StepResult

DEFAULT_TOLERANCE = 1e-4  # max |replayed - recorded| per state dimension (state units: rad, m, normalised)

# (observation the action was taken from, the action, what followed it, whether this row ends the episode)
StepHook = Callable[[Observation, npt.NDArray[np.float32], StepResult, bool], None]


@dataclass(frozen=True)
class ActionReplayer:
    """Replays recorded episodes in `env` (a scene whose spec.can_restore_state is True)."""

    env: SimRollout
    tolerance: float = DEFAULT_TOLERANCE

    def replay(self, episode: RecordedEpisode, on_step: StepHook | None = None) -> EpisodeOutcome:
        """Replay one episode. `on_step` sees every step as `record` does, e.g. to re-record it."""
        if episode.initial_state is None:
            raise ReplayError(
                f"episode {episode.index}: meta/episodes: openral.initial_state: not recorded, cannot restore its start"
            )
        n = episode.length
        recorded = episode.states.astype(np.float64)
        replayed = np.empty_like(recorded)
        obs = self.env.reset_to(episode.initial_state)
        obj_err = object_error(episode.initial_state.get("object_poses"), obs.privileged)
        if obs.state.shape != episode.states.shape[1:]:
            raise ReplayError(
                f"episode {episode.index}: the rebuilt scene produces a state of {obs.state.shape[0]} dims, the "
                f"dataset recorded {episode.states.shape[1]}"
            )
        frames = 0
        success = False
        steps = 0
        for t in range(n):
            replayed[t] = obs.state
            frames = t + 1
            action = episode.actions[t]
            result = self.env.step(action)
            steps = t + 1
            if on_step is not None:
                on_step(obs, action, result, result.terminated or t == n - 1)
            obs = result.observation
            if result.terminated:
                success = bool(result.success)
                break
        state_abs = np.abs(replayed[:frames] - recorded[:frames])
        return EpisodeOutcome(
            index=episode.index,
            steps=steps,
            success_recorded=episode.success,
            success_replayed=success,
            frames=np.arange(frames, dtype=np.int64),
            state_abs=state_abs,
            first_divergence_frame=first_exceeding(state_abs, self.tolerance),
            object_error_initial=obj_err,
        )
