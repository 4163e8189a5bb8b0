"""`--mode closed-loop`: run a policy in the rebuilt scene from each recorded episode's initial state and pair
its success with the recorded one, episode by episode.

The episode ends as `record` ends one: when the scene reports termination or after `max_steps` steps. Per frame,
the state's distance to the recorded trajectory is kept while both exist (how far the policy strays from the
demonstration); the rollouts are expected to differ, so it is information, not a failure.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from openral_data.policies.base import PolicyAdapter
from openral_data.replay.drive import StepHook, drive, restore
from openral_data.replay.outcome import EpisodeOutcome, outcome
from openral_data.replay.policy_mode import checked_action
from openral_data.replay.recorded import RecordedEpisode
from openral_data.runtime.tasks import instructed
from openral_data.types import Observation, SimRollout, StepResult


@dataclass(frozen=True)
class ClosedLoop:
    env: SimRollout
    policy: PolicyAdapter
    max_steps: int
    tolerance: float
    instruction: str | None = None  # `--instruction`: the policy's (and a re-recording's) instead of the scene's

    def run(self, episode: RecordedEpisode, on_step: StepHook | None = None) -> EpisodeOutcome:
        obs, obj_err = restore(self.env, episode)
        self.policy.reset(episode.seed or 0)
        dim = episode.actions.shape[1]
        text = self.instruction

        def act(t: int, obs: Observation) -> npt.NDArray[np.float32]:
            action = self.policy.step(obs, obs.task if text is None else text)
            return checked_action(action, dim, f"episode {episode.index} step {t}")

        hook = on_step
        if on_step is not None and text is not None:
            inner = on_step

            def hook(o: Observation, a: npt.NDArray[np.float32], r: StepResult, last: bool) -> None:
                inner(instructed(o, text), a, r, last)

        run = drive(self.env, obs, self.max_steps, act, hook)
        return outcome(episode, run.states, run.success, obj_err, self.tolerance)
