"""`maniskill`: one ManiSkill3 tabletop task (mani-skill 3.0.1, SAPIEN 3.0.3) as a SimRollout.

`gymnasium.make(env_id, sim_backend="cpu", control_mode="pd_joint_pos")` with one environment (no batching);
SAPIEN renders on the CPU through Vulkan (Mesa's lavapipe >= 23: scripts/setup_maniskill.sh). A seed is
ManiSkill's own `reset(seed=seed)`: it draws the episode's object placement and goal, so one seed is one start.

Action (8, `pd_joint_pos`): absolute targets of the Panda's seven joints (rad) + gripper (1 open .. -1 closed),
the control mode ManiSkill's motion-planning experts emit. State (9): the seven joint positions and the two
finger joints (`agent.robot.qpos`). Success: ManiSkill's own `info["success"]` (the task's `evaluate()`); the
episode ends on it. Cameras: the task's own sensors (`base_camera`, ...) at the YAML's sizes, as ManiSkill
renders them (row 0 at the top); `depth: true` adds the camera's depth in millimetres (uint16) as
`<name>_depth`. `Observation.time` is ManiSkill's elapsed control steps / control rate (20 Hz).

Restore: `initial_state()` holds the env id, control mode, seed and the flattened simulation state after the
reset (`env.get_state()`: every actor's and articulation's pose and velocities, the controller's targets);
`reset_to` resets with the same seed, which on the CPU backend gives that state again, and the same actions then
reproduce the rollout exactly. Only when the reset gives another state (another ManiSkill release) is the
recorded one set (`set_state`: the rollout then follows within ~1e-6, not bit for bit: setting poses disturbs
PhysX's contact caches). Ground truth (actor poses, the seed the expert plans with) is `Observation.privileged`.
"""

from __future__ import annotations

import contextlib
import io
import logging
from typing import Any, Literal

import numpy as np
import numpy.typing as npt
from pydantic import Field

from openral_data.errors import CompatibilityError, ConfigError
from openral_data.producers.sim.contract import check_representation, scene_spec
from openral_data.producers.sim.external import check_cameras, check_fps, require
from openral_data.producers.sim.initial_state import check_envelope
from openral_data.producers.sim.maniskill.tasks import BY_ID
from openral_data.producers.sim.params import parse_params
from openral_data.schemas.base import StrictModel
from openral_data.schemas.rskill import RSkillManifest
from openral_data.schemas.scene import SimScene, depth_camera_name
from openral_data.types import CameraShape, Observation, Privileged, StepResult

KIND = "maniskill"
STATE_FORMAT = 1
FPS = 20  # ManiSkill's tabletop control_freq
STATE_DIM = 9
ACTION_DIM = 8
CONTROL_MODE = "pd_joint_pos"
INSTALL = "bash scripts/setup_maniskill.sh, then run openral-data from .venv-maniskill (docs/scenes.md)"


class ManiSkillParams(StrictModel):
    env_id: str = Field(min_length=1, description="the ManiSkill3 task, e.g. PickCube-v1 (list tasks SCENE)")
    render_backend: Literal["cpu"] = "cpu"


def import_maniskill(source: str) -> Any:
    """gymnasium with ManiSkill's environments registered (quietly); ConfigError naming the setup if absent."""
    require("mani_skill", "maniskill", source, INSTALL)
    with contextlib.redirect_stdout(io.StringIO()):
        import gymnasium as gym
        import mani_skill.envs  # noqa: F401 - registers the environments
    logging.getLogger("mani_skill").setLevel(logging.ERROR)  # "CUDA device was not found" on every CPU machine
    return gym


def make_env(env_id: str, source: str, **kwargs: Any) -> Any:
    """ManiSkill's env for `env_id` on the CPU backend, with joint-position control (one environment)."""
    gym = import_maniskill(source)
    if env_id not in BY_ID:
        raise ConfigError(
            f"{source}: scene.params.env_id: unknown or not offline: {env_id!r}; valid: {', '.join(BY_ID)}"
        )
    return gym.make(env_id, sim_backend="cpu", control_mode=CONTROL_MODE, num_envs=1, **kwargs)


def _numpy(value: Any) -> npt.NDArray[Any]:
    """A ManiSkill tensor (batched, torch) as numpy: the first (only) environment's entry."""
    arr = value.detach().cpu().numpy() if hasattr(value, "detach") else np.asarray(value)
    return np.asarray(arr[0]) if arr.ndim > 0 and arr.shape[0] == 1 else np.asarray(arr)


class ManiSkillScene:
    def __init__(self, scene: SimScene, rskill: RSkillManifest, source: str = "scene", rskill_source: str = "rskill"):
        self.params = parse_params(ManiSkillParams, scene, source)
        check_fps(scene, FPS, source)
        if rskill.state_contract.dim != STATE_DIM or rskill.action_contract.dim != ACTION_DIM:
            raise CompatibilityError(
                f"{rskill_source}: state_contract.dim/action_contract.dim: ManiSkill's Panda produces a state of "
                f"{STATE_DIM} and takes pd_joint_pos actions of {ACTION_DIM}, "
                f"got {rskill.state_contract.dim}/{rskill.action_contract.dim}"
            )
        check_representation(
            rskill_source,
            "action",
            rskill.action_contract.representation,
            ("joint_positions_gripper", "generic"),
            "ManiSkill takes joint position targets + gripper (joint_positions_gripper)",
        )
        self._source = source
        self.instruction = scene.task.instruction
        wanted = BY_ID.get(self.params.env_id)
        if wanted is not None and wanted.instruction != self.instruction:
            raise ConfigError(
                f"{source}: task.instruction: the instruction of {self.params.env_id} is {wanted.instruction!r}; the "
                f"scene must say the same, got {self.instruction!r}"
            )
        cams = list(scene.scene.cameras)
        self._cams = [c.name for c in cams]
        self._depth = [c.name for c in cams if c.depth]
        for i, c in enumerate(cams):
            if c.segmentation:
                raise ConfigError(f"{source}: scene.cameras[{i}].segmentation: ManiSkill scenes record no segmentation")
        obs_mode = ("rgb+depth" if self._depth else "rgb") if cams else "state_dict"
        sensors = {c.name: {"width": c.width, "height": c.height} for c in cams}
        self.env: Any = make_env(self.params.env_id, source, obs_mode=obs_mode, sensor_configs=sensors)
        try:
            available = list(self.env.unwrapped._sensors)
            check_cameras(cams, available, source)
        except BaseException:
            self.close()
            raise
        shapes = {c.name: CameraShape(c.height, c.width) for c in cams}
        for c in cams:
            if c.depth:
                shapes[depth_camera_name(c.name)] = CameraShape(c.height, c.width, depth_unit="mm")
        self.spec = scene_spec(STATE_DIM, ACTION_DIM, cams, FPS, shapes=shapes, source=source)
        self._obs: dict[str, Any] = {}
        self._initial: dict[str, Any] = {}
        self._seed = 0

    # -- SimRollout ------------------------------------------------------------------------------------------
    def reset(self, seed: int) -> Observation:
        self._obs, _ = self.env.reset(seed=seed)
        self._seed = seed
        self._initial = {
            "format": STATE_FORMAT,
            "kind": KIND,
            "env_id": self.params.env_id,
            "control_mode": CONTROL_MODE,
            "seed": seed,
            "sim_state": [float(v) for v in _numpy(self.env.unwrapped.get_state())],
        }
        obs = self._observation()
        self._initial["object_poses"] = obs.privileged["object_poses"]
        return obs

    def reset_to(self, initial_state: dict[str, Any]) -> Observation:
        check_envelope(initial_state, STATE_FORMAT, KIND)
        if initial_state.get("env_id") != self.params.env_id:
            raise ConfigError(
                f"initial_state: env_id: recorded on {initial_state.get('env_id')!r}, this scene is "
                f"{self.params.env_id!r}"
            )
        try:
            seed = int(initial_state["seed"])
            state = np.asarray(initial_state["sim_state"], dtype=np.float32)
        except (KeyError, TypeError, ValueError) as exc:
            raise ConfigError(f"initial_state: does not fit ManiSkill: {exc}") from None
        self._obs, _ = self.env.reset(seed=seed)
        dim = _numpy(self.env.unwrapped.get_state()).shape[0]
        if state.shape != (dim,):
            raise ConfigError(f"initial_state: sim_state: {state.size} values, this task's state has {dim}")
        if not np.array_equal(_numpy(self.env.unwrapped.get_state()), state):
            import torch

            # the seed no longer draws the recorded start (another ManiSkill release): set the recorded state
            self.env.unwrapped.set_state(torch.from_numpy(state)[None])
            self._obs = self.env.unwrapped.get_obs()
        self._seed = seed
        self._initial = dict(initial_state)
        return self._observation()

    def step(self, action: npt.NDArray[np.float32]) -> StepResult:
        self._obs, _, _, _, info = self.env.step(np.asarray(action, dtype=np.float32))
        success = bool(_numpy(info["success"]))
        return StepResult(self._observation(), reward=float(success), success=success, terminated=success)

    def render(self) -> dict[str, npt.NDArray[Any]]:
        out: dict[str, npt.NDArray[Any]] = {}
        data = self._obs.get("sensor_data", {})
        for name in self._cams:
            out[name] = np.ascontiguousarray(_numpy(data[name]["rgb"]), dtype=np.uint8)
            if name in self._depth:
                depth = _numpy(data[name]["depth"])[..., 0]  # int16 millimetres, 0 where nothing was hit
                out[depth_camera_name(name)] = np.ascontiguousarray(np.clip(depth, 0, None), dtype=np.uint16)
        return out

    def initial_state(self) -> dict[str, Any]:
        return dict(self._initial)

    def close(self) -> None:
        env = getattr(self, "env", None)
        if env is not None:
            env.close()
            self.env = None

    # -- helpers ---------------------------------------------------------------------------------------------
    def _object_poses(self) -> dict[str, list[float]]:
        """Every actor of the task (not the robot's links) as name -> [x, y, z, qw, qx, qy, qz] (world frame)."""
        poses: dict[str, list[float]] = {}
        for name, actor in self.env.unwrapped.scene.actors.items():
            pose = actor.pose
            poses[str(name)] = [float(v) for v in (*_numpy(pose.p), *_numpy(pose.q))]
        return poses

    def _observation(self) -> Observation:
        unwrapped = self.env.unwrapped
        state = _numpy(unwrapped.agent.robot.get_qpos()).astype(np.float32)
        privileged: Privileged = {
            "object_poses": self._object_poses(),
            "joint_pos": state.astype(np.float64),
            "suite": KIND,
            "task": self.params.env_id,
            "maniskill_seed": self._seed,
        }
        steps = int(_numpy(unwrapped.elapsed_steps))
        return Observation(
            images=self.render(),
            state=state,
            task=self.instruction,
            time=steps / FPS,
            privileged=privileged,
        )
