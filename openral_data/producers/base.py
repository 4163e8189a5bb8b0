"""The seams producers plug into: observations, step results and the SimRollout protocol."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt


@dataclass(frozen=True)
class CameraShape:
    height: int
    width: int


@dataclass(frozen=True)
class ProducerSpec:
    """What a producer emits and accepts. `None` dims mean "any" (the mock accepts any action size)."""

    state_dim: int | None
    action_dim: int | None
    cameras: dict[str, CameraShape]
    fps: int
    can_restore_state: bool = False


@dataclass
class Observation:
    """What the policy sees at one step: camera images (HWC uint8), the state vector and the task text.

    `time` is the producer's clock for this observation in seconds since the episode began: simulation time
    for sim scenes, a monotonic clock for hardware. `None` means "no clock of its own" (frame index / fps).

    `privileged` is simulator ground truth (object poses, ...) that scripted experts may read; it is never
    recorded, and a learned policy must not rely on it.
    """

    images: dict[str, npt.NDArray[Any]]
    state: npt.NDArray[Any]
    task: str
    time: float | None = None
    privileged: dict[str, Any] = field(default_factory=dict)


@dataclass
class StepResult:
    observation: Observation
    reward: float
    success: bool
    terminated: bool
    info: dict[str, Any] = field(default_factory=dict)


@runtime_checkable
class SimRollout(Protocol):
    """A simulated scene. `reset(seed)` starts an episode; `step(action)` advances it by one control step.

    Replay reads simulator ground truth from `Observation.privileged["object_poses"]` when a scene provides it:
    a dict of object name -> [x, y, z, qw, qx, qy, qz] (world frame), compared with the recorded initial
    state's `object_poses` of the same form.

    Arrays returned in observations belong to the caller (a producer must not write into them later).
    """

    spec: ProducerSpec

    def reset(self, seed: int) -> Observation: ...

    def step(self, action: npt.NDArray[np.float32]) -> StepResult: ...

    def render(self) -> dict[str, npt.NDArray[np.uint8]]: ...

    def initial_state(self) -> dict[str, Any]:
        """JSON-serialisable data that restores the state `reset` produced (for replay)."""
        ...

    def reset_to(self, initial_state: dict[str, Any]) -> Observation:
        """Start an episode from exactly the state `initial_state()` described when it was recorded (replay).

        Valid only when `spec.can_restore_state`; a scene that cannot restore a state keeps it False and raises
        an OpenralError here. From the restored state, the same actions must give the same rollout.
        """
        ...

    def close(self) -> None: ...
