"""The `mock` scene: no physics, fully deterministic, for verifying alignment end to end.

At step t of episode e the state is `[t, e, 0, ...]` (float32, contract dim) and every camera frame is a solid
colour (R = t mod 256, G = e mod 256, B = 128), so a decoded video frame says which row it belongs to.
The episode succeeds after `success_after` steps (an int, or a list cycled over episodes). Any action size
is accepted. With `seeded: true` the episode number e is the reset seed instead of a count of resets, so
an episode looks the same whichever process records it (parallel recording). `step_sleep` (seconds, an int/float
or a list cycled over episodes like `success_after`) makes stepping slow on purpose. `fault` params inject
contract violations at a given step so the bridge can be tested through the whole pipeline.
"""

from __future__ import annotations

import time
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
from pydantic import Field

from openral_data.errors import ConfigError
from openral_data.producers.sim.contract import scene_spec
from openral_data.producers.sim.params import parse_params
from openral_data.schemas.base import StrictModel
from openral_data.schemas.scene import SimScene
from openral_data.types import Observation, StepResult

FaultKind = Literal["nan_state", "float_image", "wrong_image_shape", "extra_camera", "missing_camera", "state_dim"]


class MockFault(StrictModel):
    kind: FaultKind
    at_step: int = Field(default=0, ge=0)
    episode: int = Field(default=0, ge=0)


class MockParams(StrictModel):
    success_after: int | list[int] = 10
    state_dim: int | None = Field(default=None, gt=0, description="default: the rSkill state contract dim")
    fault: MockFault | None = None
    seeded: bool = False
    step_sleep: float | list[float] = Field(default=0.0)


class MockScene:
    """Deterministic producer; see the module docstring."""

    def __init__(self, scene: SimScene, state_dim: int, source: str = "scene") -> None:
        self.params = parse_params(MockParams, scene, source)
        if isinstance(self.params.success_after, list) and (
            not self.params.success_after or min(self.params.success_after) < 1
        ):
            raise ConfigError(f"{source}: scene.params.success_after: needs positive step counts")
        self._state_dim = self.params.state_dim or state_dim
        self._task = scene.task.instruction
        self.spec = scene_spec(self._state_dim, None, scene.scene.cameras, scene.scene.fps, source=source)
        self._episode = -1
        self._t = 0
        self._seed = 0

    def _success_after(self) -> int:
        s = self.params.success_after
        return s if isinstance(s, int) else s[self._episode % len(s)]

    def _step_sleep(self) -> float:
        s = self.params.step_sleep
        return float(s) if not isinstance(s, list) else float(s[self._episode % len(s)]) if s else 0.0

    def _observation(self) -> Observation:
        t, e = self._t, self._episode
        state: npt.NDArray[Any] = np.zeros(self._state_dim, dtype=np.float32)
        state[0] = t
        if self._state_dim > 1:
            state[1] = e
        images: dict[str, npt.NDArray[Any]] = {}
        colour = np.array([t % 256, e % 256, 128], dtype=np.uint8)
        for name, shape in self.spec.cameras.items():
            image = np.empty((shape.height, shape.width * 3), dtype=np.uint8)
            image[:] = np.tile(colour, shape.width)  # row by row: ~8x faster than copying a broadcast pixel
            images[name] = image.reshape(shape.height, shape.width, 3)
        fault = self.params.fault
        if fault is not None and fault.episode == e and fault.at_step == t:
            state, images = self._inject(fault.kind, state, images)
        return Observation(images=images, state=state, task=self._task, time=t / self.spec.fps)

    @staticmethod
    def _inject(
        kind: str, state: npt.NDArray[Any], images: dict[str, npt.NDArray[Any]]
    ) -> tuple[npt.NDArray[Any], dict[str, npt.NDArray[Any]]]:
        first = next(iter(images), None)
        if kind == "nan_state":
            state = state.copy()
            state[-1] = np.nan
        elif kind == "state_dim":
            state = np.append(state, np.float32(0))
        elif kind == "float_image" and first is not None:
            images[first] = images[first].astype(np.float32) / 255.0
        elif kind == "wrong_image_shape" and first is not None:
            images[first] = images[first][:-2]
        elif kind == "extra_camera":
            images["undeclared_cam"] = np.zeros((8, 8, 3), dtype=np.uint8)
        elif kind == "missing_camera" and first is not None:
            del images[first]
        return state, images

    def start_at(self, episode: int) -> None:
        """Continue the episode numbering (`record --resume`): the next `reset` is episode `episode`."""
        self._episode = episode - 1

    def reset(self, seed: int) -> Observation:
        self._episode = seed if self.params.seeded else self._episode + 1
        self._seed = seed
        self._t = 0
        return self._observation()

    def step(self, action: npt.NDArray[np.float32]) -> StepResult:
        self._t += 1
        pause = self._step_sleep()
        if pause > 0:
            time.sleep(pause)
        success = self._t >= self._success_after()
        return StepResult(self._observation(), reward=float(success), success=success, terminated=success)

    def render(self) -> dict[str, npt.NDArray[np.uint8]]:
        return self._observation().images

    def initial_state(self) -> dict[str, Any]:
        return {"episode": self._episode, "seed": self._seed}

    def reset_to(self, initial_state: dict[str, Any]) -> Observation:
        """Restart episode `initial_state["episode"]` at step 0 (the mock's whole state is (episode, step))."""
        try:
            episode, seed = int(initial_state["episode"]), int(initial_state["seed"])
        except (KeyError, TypeError, ValueError):
            raise ConfigError(
                f"initial_state: expected {{'episode': int, 'seed': int}} from a mock recording, got {initial_state}"
            ) from None
        if episode < 0:
            raise ConfigError(f"initial_state: episode: must be >= 0, got {episode}")
        self._episode, self._seed, self._t = episode, seed, 0
        return self._observation()

    def close(self) -> None:
        pass
