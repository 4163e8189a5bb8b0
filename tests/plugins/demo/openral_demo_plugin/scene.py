"""`slider`: a point mass on a rail, pushed by a force; success once it rests within `tolerance` of `target`.

State: [position, velocity] (metres, m/s). Action: [force] (N). One camera draws the rail: a white column at the
mass's position, a green one at the target.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from openral_data.schemas.robot import RobotManifest
from openral_data.schemas.rskill import RSkillManifest
from openral_data.schemas.scene import SimScene
from openral_data.types import CameraShape, Observation, ProducerSpec, StepResult


class SliderScene:
    def __init__(self, scene: SimScene) -> None:
        params = scene.scene.params
        self.target = float(params.get("target", 0.5))
        self.tolerance = float(params.get("tolerance", 0.02))
        self.mass = float(params.get("mass", 1.0))
        self.dt = 1.0 / scene.scene.fps
        self.task = scene.task.instruction
        cams = {c.name: CameraShape(c.height, c.width) for c in scene.scene.cameras}
        self.spec = ProducerSpec(state_dim=2, action_dim=1, cameras=cams, fps=scene.scene.fps, can_restore_state=True)
        self.x = 0.0
        self.v = 0.0
        self.t = 0.0

    def _obs(self) -> Observation:
        state = np.array([self.x, self.v], dtype=np.float32)
        return Observation(images=self.render(), state=state, task=self.task, time=self.t)

    def reset(self, seed: int) -> Observation:
        self.x = float(np.random.default_rng(seed).uniform(-0.5, 0.0))
        self.v, self.t = 0.0, 0.0
        return self._obs()

    def reset_to(self, initial_state: dict[str, Any]) -> Observation:
        self.x, self.v, self.t = float(initial_state["x"]), 0.0, 0.0
        return self._obs()

    def initial_state(self) -> dict[str, Any]:
        return {"x": self.x}

    def step(self, action: npt.NDArray[np.float32]) -> StepResult:
        self.v += float(action[0]) / self.mass * self.dt
        self.x += self.v * self.dt
        self.t += self.dt
        success = abs(self.x - self.target) < self.tolerance and abs(self.v) < 0.05
        return StepResult(self._obs(), reward=-abs(self.x - self.target), success=success, terminated=success)

    def render(self) -> dict[str, npt.NDArray[np.uint8]]:
        out: dict[str, npt.NDArray[np.uint8]] = {}
        for name, shape in self.spec.cameras.items():
            img = np.zeros((shape.height, shape.width, 3), dtype=np.uint8)
            for pos, colour in ((self.target, (0, 255, 0)), (self.x, (255, 255, 255))):
                col = round((pos + 1.0) / 2.0 * (shape.width - 1))
                img[:, min(max(col, 0), shape.width - 1)] = colour
            out[name] = img
        return out

    def close(self) -> None:
        pass


def make_slider(scene: SimScene, robot: RobotManifest, rskill: RSkillManifest, source: str) -> SliderScene:
    return SliderScene(scene)
