"""Running the rebuilt scene along a recorded episode, shared by `--mode actions` and `--mode closed-loop`:
restore the episode's start, then step until the scene terminates or the step budget is spent, exactly as
`record` ends an episode."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from openral_data.errors import ReplayError
from openral_data.replay.outcome import F64, object_error
from openral_data.replay.recorded import RecordedEpisode
from openral_data.types import Observation, SimRollout, StepResult

# (observation the action was taken from, the action, what followed it, whether this row ends the episode)
StepHook = Callable[[Observation, npt.NDArray[np.float32], StepResult, bool], None]
# (step index, observation) -> the action to apply
ActionSource = Callable[[int, Observation], npt.NDArray[np.float32]]


@dataclass(frozen=True)
class Drive:
    """What a drive produced: the state each applied action was taken from, and the scene's success at the end."""

    states: list[F64]
    success: bool


def restore(env: SimRollout, episode: RecordedEpisode) -> tuple[Observation, float | None]:
    """Put `env` in the episode's recorded initial state: the first observation and the largest object position
    error right after the restore (None when either side has no object poses)."""
    if episode.initial_state is None:
        raise ReplayError(
            f"episode {episode.index}: meta/episodes: openral.initial_state: not recorded, cannot restore its start"
        )
    obs = env.reset_to(episode.initial_state)
    return obs, object_error(episode.initial_state.get("object_poses"), obs.privileged)


def drive(
    env: SimRollout, obs: Observation, max_steps: int, action_at: ActionSource, on_step: StepHook | None = None
) -> Drive:
    """Step `env` from `obs` with `action_at`'s actions until it terminates or `max_steps` actions are applied;
    `on_step` sees every step as `record` does, e.g. to re-record it."""
    states: list[F64] = []
    success = False
    for t in range(max_steps):
        states.append(np.asarray(obs.state, dtype=np.float64))
        action = action_at(t, obs)
        result = env.step(action)
        if on_step is not None:
            on_step(obs, action, result, result.terminated or t == max_steps - 1)
        obs = result.observation
        if result.terminated:
            success = bool(result.success)
            break
    return Drive(states, success)
