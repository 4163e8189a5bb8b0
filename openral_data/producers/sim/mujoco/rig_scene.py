"""The part of a SimRollout that is the same in every MuJoCo scene drawn through a CameraRig (tabletop,
robosuite, MetaWorld, gym-aloha): `render`, `initial_state`, `close`, and assembling an Observation."""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from openral_data.producers.sim.contract import object_pose_vector
from openral_data.producers.sim.mujoco.render import CameraRig
from openral_data.types import Observation, Privileged


class RigScene:
    """Subclasses set `rig` (their cameras), `data` (the MuJoCo state drawn), `initial` (this episode's start,
    as `initial_state()` hands it out) and `task_text`; `t0` is the simulation time the episode began at (where
    the simulator's clock does not restart with the episode); one wrapping a simulator environment sets `env`,
    closed last."""

    rig: CameraRig
    data: mujoco.MjData
    initial: dict[str, Any]
    task_text: str
    t0: float = 0.0
    env: Any = None
    environment_objects: tuple[str, ...] = ()

    def observe(self, state: npt.NDArray[np.float32], privileged: Privileged) -> Observation:
        """The current frames, `state`, the task text and the time since the episode began."""
        objects = self.environment_objects
        poses = {**privileged.get("fixed_poses", {}), **privileged["object_poses"]} if objects else {}
        return Observation(
            images=self.render(),
            state=state,
            task=self.task_text,
            time=float(self.data.time) - self.t0,
            privileged=privileged,
            environment_state=object_pose_vector(poses, objects) if objects else None,
            transforms=self.rig.mount_poses(self.data),
        )

    def render(self) -> dict[str, npt.NDArray[Any]]:
        return self.rig.render(self.data)

    def initial_state(self) -> dict[str, Any]:
        return dict(self.initial)

    def close(self) -> None:
        self.rig.close()
        if self.env is not None:
            self.env.close()
