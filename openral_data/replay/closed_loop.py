"""`--mode closed-loop`: run a policy in the rebuilt scene from each recorded episode's initial state and pair
its success with the recorded one, episode by episode.

The episode ends as `record` ends one: when the scene reports termination or after `max_steps` steps. Per frame,
the state's distance to the recorded trajectory is kept while both exist (how far the policy strays from the
demonstration); the rollouts are expected to differ, so it is information, not a failure.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from openral_data.errors import ReplayError
from openral_data.policies.base import PolicyAdapter
from openral_data.replay.actions import StepHook
from openral_data.replay.outcome import EpisodeOutcome, first_exceeding, object_error
from openral_data.replay.policy_mode import checked_action
from openral_data.replay.recorded import RecordedEpisode
from openral_data.types import SimRollout


@dataclass(frozen=True)
class ClosedLoop:
    env: SimRollout
    policy: PolicyAdapter
    max_steps: int
    tolerance: float

    def run(self, episode: RecordedEpisode, on_step: StepHook | None = None) -> EpisodeOutcome:
        if episode.initial_state is None:
            raise ReplayError(
                f"episode {episode.index}: meta/episodes: openral.initial_state: not recorded, cannot restore its start"
            )
        obs = self.env.reset_to(episode.initial_state)
        obj_err = object_error(episode.initial_state.get("object_poses"), obs.privileged)
        self.policy.reset(episode.seed or 0)
        dim = episode.actions.shape[1]
        states = []
        success = False
        steps = 0
        for t in range(self.max_steps):
            states.append(np.asarray(obs.state, dtype=np.float64))
            action = checked_action(self.policy.step(obs, obs.task), dim, f"episode {episode.index} step {t}")
            result = self.env.step(action)
            steps = t + 1
            if on_step is not None:
                on_step(obs, action, result, result.terminated or t == self.max_steps - 1)
            obs = result.observation
            if result.terminated:
                success = bool(result.success)
                break
        m = min(len(states), episode.length)
        state_abs = np.abs(np.array(states[:m]) - episode.states[:m].astype(np.float64))
        return EpisodeOutcome(
            index=episode.index,
            steps=steps,
            success_recorded=episode.success,
            success_replayed=success,
            frames=np.arange(m, dtype=np.int64),
            state_abs=state_abs,
            first_divergence_frame=first_exceeding(state_abs, self.tolerance),
            object_error_initial=obj_err,
        )
