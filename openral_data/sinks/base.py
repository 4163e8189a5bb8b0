"""What the bridge hands to sinks: a validated dataset schema, frames and episode records."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from openral_data.producers.base import CameraShape


@dataclass(frozen=True)
class DatasetSchema:
    """Everything a sink needs to lay out a dataset before the first frame arrives."""

    fps: int
    state_names: tuple[str, ...]
    action_names: tuple[str, ...]
    cameras: dict[str, CameraShape]
    robot_type: str
    metadata: dict[str, Any] = field(default_factory=dict)  # scene / rSkill / robot provenance
    # Which outcomes the source knows. A sink stores no reward / success it was not given (a converted hardware
    # log has none): the frames' `reward` / `success` values are then ignored and episode success is unknown.
    has_reward: bool = True
    has_success: bool = True
    # Extra per-frame float columns (e.g. a HAL's real monotonic timestamps, overrun and safety flags); every
    # frame must carry exactly these keys in `Frame.extras`. LeRobot v3: float32 features of shape [1].
    frame_extras: tuple[str, ...] = ()

    @property
    def state_dim(self) -> int:
        return len(self.state_names)

    @property
    def action_dim(self) -> int:
        return len(self.action_names)


@dataclass
class Frame:
    """Row t: the observation the policy saw at step t, the action it produced, and what followed."""

    state: npt.NDArray[np.float32]
    action: npt.NDArray[np.float32]
    images: dict[str, npt.NDArray[np.uint8]]
    task: str
    reward: float
    done: bool
    success: bool
    timestamp: float = 0.0  # seconds since the episode began, from the producer's clock (see Observation.time)
    extras: dict[str, float] = field(default_factory=dict)  # DatasetSchema.frame_extras values


@dataclass(frozen=True)
class EpisodeStart:
    seed: int
    initial_state: dict[str, Any]


@dataclass(frozen=True)
class EpisodeRecord:
    """What a sink reports for a finished, durable episode."""

    index: int
    length: int
    success: bool | None  # None: unknown (the source says nothing about success)
    seed: int


class Sink(Protocol):
    def begin_episode(self, start: EpisodeStart) -> None: ...

    def add_frame(self, frame: Frame) -> None: ...

    def end_episode(self, success: bool | None) -> EpisodeRecord: ...

    def discard_episode(self) -> None: ...

    def close(self) -> None: ...


class EpisodeAnnotations(Protocol):
    """Optional sink capability: JSON-able facts about the episode in flight (a HAL's overruns, safety
    interventions, operator verdict), stored with the episode's record. The bridge calls it when a sink has it."""

    def annotate_episode(self, info: dict[str, Any]) -> None: ...
