"""What one replayed/evaluated episode yields, and the error statistics shared by every mode."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from openral_data.replay.recorded import RecordedEpisode
from openral_data.types import Privileged

F64 = npt.NDArray[np.float64]


@dataclass
class EpisodeOutcome:
    """One episode of any mode. Per-step arrays are aligned with `frames` (the dataset's frame indices).

    `state_abs` (frames x state dims) is |replayed state - recorded state| (actions mode; closed-loop has none,
    the rollouts differ by design); `action_abs` (frames x action dims) is |policy action - recorded action|
    (policy mode). `steps` is how many actions were applied or compared.
    """

    index: int
    steps: int
    success_recorded: bool | None
    success_replayed: bool | None
    frames: npt.NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    state_abs: F64 | None = None
    action_abs: F64 | None = None
    first_divergence_frame: int | None = None
    object_error_initial: float | None = None
    overruled: bool = False  # the recorded success is an operator's verdict the scene's criterion contradicted

    @property
    def divergence(self) -> F64 | None:
        """Per frame: Euclidean norm of the state error."""
        return None if self.state_abs is None else np.sqrt((self.state_abs**2).sum(axis=1))

    @property
    def action_error(self) -> F64 | None:
        """Per compared step: Euclidean norm of the action error."""
        return None if self.action_abs is None else np.sqrt((self.action_abs**2).sum(axis=1))

    @property
    def success_agrees(self) -> bool | None:
        if self.success_recorded is None or self.success_replayed is None:
            return None
        return self.success_recorded == self.success_replayed


def outcome(
    episode: RecordedEpisode,
    states: Sequence[F64],
    success: bool,
    object_error_initial: float | None,
    tolerance: float,
) -> EpisodeOutcome:
    """The outcome of a scene run from `episode`'s start: `states` are the states the applied actions were taken
    from (one per step), compared with the recorded ones while both exist."""
    m = min(len(states), episode.length)
    recorded = episode.states[:m].astype(np.float64)
    replayed = np.array(states[:m], dtype=np.float64) if m else np.zeros_like(recorded)
    state_abs = np.abs(replayed - recorded)
    return EpisodeOutcome(
        index=episode.index,
        steps=len(states),
        success_recorded=episode.success,
        success_replayed=success,
        frames=np.arange(m, dtype=np.int64),
        state_abs=state_abs,
        first_divergence_frame=first_exceeding(state_abs, tolerance),
        object_error_initial=object_error_initial,
        overruled=episode.overruled,
    )


def first_exceeding(abs_error: F64, tolerance: float) -> int | None:
    """Row of the first frame whose max-abs error is above `tolerance`, or None."""
    if abs_error.size == 0:
        return None
    over = np.flatnonzero(abs_error.max(axis=1) > tolerance)
    return int(over[0]) if over.size else None


def object_error(recorded: object, privileged: Privileged) -> float | None:
    """Largest position error between the recorded `object_poses` and the replayed ones, if both exist."""
    replayed = privileged.get("object_poses")
    if not isinstance(recorded, dict) or not isinstance(replayed, dict):
        return None
    common = [name for name in recorded if name in replayed]
    if not common:
        return None
    errors = [
        float(
            np.linalg.norm(
                np.asarray(replayed[n], dtype=np.float64)[:3] - np.asarray(recorded[n], dtype=np.float64)[:3]
            )
        )
        for n in common
    ]
    return max(errors)


def overruled_line(o: EpisodeOutcome) -> str:
    """Why an episode whose recorded success is an operator's verdict (`overruled`) does not reproduce it."""
    said, scene = ("success", "not successful") if o.success_recorded else ("failure", "successful")
    return f"ep {o.index}: the recorded {said} came from the operator's verdict; the scene's criterion said {scene}"
