"""`gym_aloha`: gym-aloha 0.1.5's bimanual ViperX tasks (insertion, transfer cube) as a SimRollout.

Built from gym-aloha's own parts: its MJCF scenes, its dm_control task classes (action mapping in
`before_step`, the reward stages 0..4 and `max_reward`), its seeded pose samplers and its 50 Hz control step.
Action and state are gym-aloha's 14 numbers: per arm 6 absolute joint positions + the gripper normalised
0 = closed .. 1 = open (left arm first). Success is gym-aloha's: reward == 4 (transfer: the left gripper holds
the cube off the table; insertion: the peg touches the pin); the reward recorded is that stage.

Cameras are the scene's own (`top`, `angle`, `front_close`, `left_pillar`, `right_pillar`, `left_wrist`,
`right_wrist`), rendered only if the YAML asks, at the YAML's size, with shadows/reflections per `render:`
(gym-aloha's env renders three 640×480 views every step whatever is used, which is what makes it run at
3–9 steps/s here; its task's observation hook is replaced by one without images). Ground truth (`object_poses`,
reward stage) is `Observation.privileged`, never recorded. `Observation.time` is MuJoCo time.

Restore: an episode's start is fully given by the sampled object poses (the arms start at gym-aloha's
START_ARM_POSE); `reset_to` re-runs gym-aloha's reset with them, and the same actions reproduce the rollout
bit for bit (tested).
"""

from __future__ import annotations

from typing import Any, Literal

import mujoco
import numpy as np
import numpy.typing as npt
from pydantic import Field

from openral_data.errors import CompatibilityError, ConfigError
from openral_data.producers.sim.contract import scene_spec
from openral_data.producers.sim.external import check_fps, named_cameras, require
from openral_data.producers.sim.initial_state import check_envelope, check_recorded_on
from openral_data.producers.sim.mujoco.render import CameraRig
from openral_data.producers.sim.mujoco.rig_scene import RigScene
from openral_data.producers.sim.params import parse_params
from openral_data.producers.sim.tasks import SuiteTask
from openral_data.schemas.base import StrictModel
from openral_data.schemas.rskill import RSkillManifest
from openral_data.schemas.scene import SimScene
from openral_data.types import Observation, Privileged, StepResult

KIND = "gym_aloha"
STATE_FORMAT = 1
FPS = 50  # gym-aloha's DT = 0.02 s
DIM = 14
CAMERAS = ("top", "angle", "front_close", "left_pillar", "right_pillar", "left_wrist", "right_wrist")
AlohaTask = Literal["insertion", "transfer_cube"]


# the shipped scenes' instructions (gym-aloha has no language of its own)
INSTRUCTIONS: dict[AlohaTask, str] = {
    "insertion": "Pick up the peg and the socket, one in each arm, and insert the peg into the socket.",
    "transfer_cube": "Pick up the red cube with the right arm and hand it over to the left arm.",
}


def suite_tasks(scene: SimScene, source: str) -> list[SuiteTask]:
    """gym-aloha's two tasks (`--task insertion`, `--task transfer_cube`)."""
    return [SuiteTask(name, text, {"task": name}) for name, text in INSTRUCTIONS.items()]


class AlohaParams(StrictModel):
    task: AlohaTask = Field(description="gym-aloha task")


def _task_without_images(base: type[Any]) -> Any:
    """gym-aloha's task with an observation hook that skips its three 640×480 renders."""

    class Task(base):  # type: ignore[misc]
        def get_observation(self, physics: Any) -> dict[str, Any]:
            return {"qpos": self.get_qpos(physics), "qvel": self.get_qvel(physics)}

    return Task()


class AlohaScene(RigScene):
    def __init__(self, scene: SimScene, rskill: RSkillManifest, source: str = "scene", rskill_source: str = "rskill"):
        params = parse_params(AlohaParams, scene, source)
        check_fps(scene, FPS, source)
        cams = named_cameras(scene, CAMERAS, source)
        for side, contract in (("state", rskill.state_contract), ("action", rskill.action_contract)):
            if contract.dim != DIM:
                raise CompatibilityError(
                    f"{rskill_source}: {side}_contract.dim: gym-aloha uses 14 numbers (2 × 6 joints + gripper), "
                    f"got {contract.dim}"
                )
        require("gym_aloha", "aloha", source)
        from dm_control import mujoco as dm_mujoco
        from dm_control.rl import control
        from gym_aloha import constants, utils
        from gym_aloha.tasks import sim

        self.task_name: AlohaTask = params.task
        xml = "bimanual_viperx_insertion.xml" if params.task == "insertion" else "bimanual_viperx_transfer_cube.xml"
        self.physics: Any = dm_mujoco.Physics.from_xml_path(str(constants.ASSETS_DIR / xml))
        base = sim.InsertionTask if params.task == "insertion" else sim.TransferCubeTask
        self._task: Any = _task_without_images(base)
        self._env: Any = control.Environment(
            self.physics, self._task, float("inf"), control_timestep=constants.DT, n_sub_steps=None,
            flat_observation=False,
        )  # fmt: skip
        self._sim: Any = sim
        self._sample = utils.sample_insertion_pose if params.task == "insertion" else utils.sample_box_pose
        self._objects = ("red_peg", "socket") if params.task == "insertion" else ("red_box",)
        # gym-aloha's MJCF draws its arms in geom group 1: MuJoCo's default groups, not the composed scenes'
        self.data = self.physics.data.ptr  # the same MjData for the scene's life (resets are in place)
        self.rig = CameraRig(self.physics.model.ptr, cams, scene.scene.render, option=mujoco.MjvOption())
        if scene.scene.observations.environment_state:
            self.environment_objects = self._objects
        self.spec = scene_spec(
            DIM, DIM, cams, FPS, shapes=self.rig.shapes(), environment_objects=self.environment_objects
        )
        self.task_text = scene.task.instruction
        self._seed = 0
        self.initial = {}
        self._stage = 0

    # -- SimRollout ------------------------------------------------------------------------------------------
    def reset(self, seed: int) -> Observation:
        sampled = self._sample(seed)
        poses = np.concatenate(sampled) if isinstance(sampled, tuple) else np.asarray(sampled)
        return self._reset_with(seed, poses)

    def reset_to(self, initial_state: dict[str, Any]) -> Observation:
        check_envelope(initial_state, STATE_FORMAT, KIND)
        check_recorded_on(initial_state, "task", self.task_name, this="this is")
        try:
            recorded = initial_state["object_poses"]
            poses = np.concatenate([np.asarray(recorded[n], dtype=np.float64).reshape(7) for n in self._objects])
            seed = int(initial_state["seed"])
        except (KeyError, TypeError, ValueError) as exc:
            raise ConfigError(f"initial_state: does not fit gym-aloha {self.task_name}: {exc}") from None
        return self._reset_with(seed, poses)

    def step(self, action: npt.NDArray[np.float32]) -> StepResult:
        ts = self._env.step(np.asarray(action, dtype=np.float64))
        self._stage = int(ts.reward)
        success = self._stage == self._task.max_reward
        return StepResult(self._observation(ts.observation), reward=float(self._stage), success=success,
                          terminated=success)  # fmt: skip

    # -- helpers ---------------------------------------------------------------------------------------------
    def _reset_with(self, seed: int, poses: npt.NDArray[np.float64]) -> Observation:
        self._seed = seed
        self._sim.BOX_POSE[0] = poses  # gym-aloha's tasks read the object poses from this module global
        ts = self._env.reset()
        self._stage = 0
        d = self.physics.data
        self.initial = {
            "format": STATE_FORMAT,
            "kind": KIND,
            "task": self.task_name,
            "seed": seed,
            "object_poses": self._object_poses(),
            "time": float(d.time),
            "qpos": d.qpos.tolist(),
            "ctrl": d.ctrl.tolist(),
        }
        return self._observation(ts.observation)

    def _object_poses(self) -> dict[str, list[float]]:
        """Free objects' poses [x, y, z, qw, qx, qy, qz] (world); they follow the 16 arm joints in qpos."""
        q = self.physics.data.qpos
        return {name: [float(v) for v in q[16 + 7 * i : 23 + 7 * i]] for i, name in enumerate(self._objects)}

    def _observation(self, raw: dict[str, Any]) -> Observation:
        privileged: Privileged = {
            "object_poses": self._object_poses(),
            "reward_stage": self._stage,
            "qvel": np.asarray(raw["qvel"], dtype=np.float64),
        }
        return self.observe(np.asarray(raw["qpos"], dtype=np.float32), privileged)
