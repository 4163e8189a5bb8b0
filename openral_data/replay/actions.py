"""`--mode actions`: restore each episode's recorded initial state, feed the recorded actions step by step and
compare the states the scene produces with the recorded ones.

Frame t of the comparison is the observation after the t actions 0..t-1 (frame 0 checks the restore itself).
The replay stops where the recording stopped: after the last recorded action, or earlier when the scene
reports termination (the recorder ends an episode there too). The replayed success is the scene's success at
that point, exactly as `record` decides it.
"""

from __future__ import annotations

from dataclasses import dataclass

from openral_data.errors import ReplayError
from openral_data.replay.drive import StepHook, drive, restore
from openral_data.replay.outcome import EpisodeOutcome, outcome
from openral_data.replay.recorded import RecordedEpisode
from openral_data.types import SimRollout

DEFAULT_TOLERANCE = 1e-4  # max |replayed - recorded| per state dimension (state units: rad, m, normalised)


@dataclass(frozen=True)
class ActionReplayer:
    """Replays recorded episodes in `env` (a scene whose spec.can_restore_state is True)."""

    env: SimRollout
    tolerance: float = DEFAULT_TOLERANCE

    def replay(self, episode: RecordedEpisode, on_step: StepHook | None = None) -> EpisodeOutcome:
        """Replay one episode. `on_step` sees every step as `record` does, e.g. to re-record it."""
        obs, obj_err = restore(self.env, episode)
        if obs.state.shape != episode.states.shape[1:]:
            raise ReplayError(
                f"episode {episode.index}: the rebuilt scene produces a state of {obs.state.shape[0]} dims, the "
                f"dataset recorded {episode.states.shape[1]}"
            )
        run = drive(self.env, obs, episode.length, lambda t, _: episode.actions[t], on_step)
        return outcome(episode, run.states, run.success, obj_err, self.tolerance)
