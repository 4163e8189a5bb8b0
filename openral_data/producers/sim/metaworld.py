"""`metaworld` scenes: any MetaWorld 3.1.1 v3 task, through its gymnasium API (`Meta-World/MT1`), as a SimRollout.

The robot is MetaWorld's mocap-driven Sawyer (manifest `metaworld_sawyer`, fixed). As in lerobot's MetaWorld
environment, the recorded state is the first four entries of MetaWorld's observation (hand x, y, z and the
gripper opening) and the action is MetaWorld's own 4-vector [dx, dy, dz, grab effort] in [-1, 1] (1 cm per unit
per step), stored as emitted. The full 39-entry observation (object poses, goal) goes to
`Observation.privileged` for the scripted experts and is never recorded. Success is MetaWorld's
`info["success"]`, the reward its v2 shaped reward. The control rate is fixed by the simulator (80 Hz: 2.5 ms
physics steps, frame skip 5); the scene's `fps` must say so. `Observation.time` is simulation time since reset.

Seeds: every MetaWorld task draws its object and goal placement (`rand_vec`) from the environment's generator;
`reset(seed)` seeds it (`env.seed(seed)`, like lerobot's `MetaworldEnv.reset(seed=...)`), so one seed is one
initial state across the whole placement space, with the goal observable; `reset_to` repeats that reset and checks
it reproduces the recorded state. MetaWorld ends an episode after 500
steps (TimeLimit): the scene then reports it terminated. Cameras: the model's named cameras (`corner`,
`corner2`, `corner3`, `topview`, `behindGripper`, `gripperPOV`), rendered upright by named_cameras.py.
"""

from __future__ import annotations

import importlib.util
import json
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from pydantic import Field

import openral_data.producers.sim.mujoco  # noqa: F401  (chooses a headless MUJOCO_GL before mujoco loads)
from openral_data.errors import ConfigError, install_hint
from openral_data.producers.sim import mjstate
from openral_data.producers.sim.contract import Side, check_representation, scene_spec
from openral_data.producers.sim.initial_state import check_recorded_on
from openral_data.producers.sim.mujoco.rig_scene import RigScene
from openral_data.producers.sim.named_cameras import named_camera_rig
from openral_data.producers.sim.params import parse_params
from openral_data.producers.sim.tasks import SuiteTask
from openral_data.schemas.base import StrictModel
from openral_data.schemas.robot import RobotManifest
from openral_data.schemas.rskill import RSkillManifest
from openral_data.schemas.scene import SimScene
from openral_data.types import Observation, Privileged, StepResult

STATE_FORMAT = 1
ROBOT = "metaworld_sawyer"
STATE_DIM = 4  # hand xyz + gripper distance apart (lerobot's `agent_pos`)
ACTION_DIM = 4
REPRESENTATIONS = ("generic",)


class MetaWorldParams(StrictModel):
    task: str = Field(min_length=1, description="a MetaWorld v3 task name, e.g. pick-place-v3")
    terminate_on_success: bool = True


def import_metaworld() -> Any:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import metaworld
    except ImportError:
        raise ConfigError(f"metaworld scenes need the 'metaworld' extra: {install_hint('metaworld')}") from None
    return metaworld


def task_names() -> list[str]:
    import_metaworld()
    from metaworld.env_dict import ALL_V3_ENVIRONMENTS

    return sorted(ALL_V3_ENVIRONMENTS)


def task_instructions() -> dict[str, str]:
    """lerobot 0.6.1's MetaWorld task descriptions (`lerobot/envs/metaworld_config.json`; the shipped scenes' own
    instructions): read from the file, since importing `lerobot.envs.metaworld` would build its environments."""
    spec = importlib.util.find_spec("lerobot")
    if spec is None or not spec.submodule_search_locations:
        return {}
    path = Path(next(iter(spec.submodule_search_locations))) / "envs" / "metaworld_config.json"
    try:
        found = json.loads(path.read_text()).get("TASK_DESCRIPTIONS", {})
    except (OSError, ValueError):
        return {}
    return {str(k): str(v) for k, v in found.items()} if isinstance(found, dict) else {}


def suite_tasks(scene: SimScene, source: str) -> list[SuiteTask]:
    """Every MetaWorld v3 task of this wheel (`--task pick-place-v3`), with lerobot's description as its
    instruction (the task's own name, spelt out, where lerobot has none)."""
    described = task_instructions()
    return [
        SuiteTask(name, described.get(name) or name.removesuffix("-v3").replace("-", " "), {"task": name})
        for name in task_names()
    ]


class MetaWorldScene(RigScene):
    """One MetaWorld task, built once through `gymnasium.make`; `reset(seed)` per episode."""

    def __init__(
        self, scene: SimScene, robot: RobotManifest, rskill: RSkillManifest, source: str, rskill_source: str
    ) -> None:
        self.params = parse_params(MetaWorldParams, scene, source)
        if robot.name != ROBOT:
            raise ConfigError(f"{source}: scene.robot: MetaWorld tasks fix the robot to {ROBOT!r}, got {robot.name!r}")
        valid = task_names()
        if self.params.task not in valid:
            raise ConfigError(
                f"{source}: scene.params.task: unknown MetaWorld task {self.params.task!r}; valid: {', '.join(valid)}"
            )
        contracts: tuple[tuple[Side, str], ...] = (
            ("state", rskill.state_contract.representation),
            ("action", rskill.action_contract.representation),
        )
        for side, rep in contracts:
            check_representation(
                rskill_source,
                side,
                rep,
                REPRESENTATIONS,
                f"{rep!r} is not spoken by MetaWorld scenes "
                "(state: generic [hand x, y, z, gripper]; action: generic [dx, dy, dz, grab])",
            )
        import gymnasium as gym

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            env: Any = gym.make(
                "Meta-World/MT1", env_name=self.params.task, seed=0, render_mode=None, disable_env_checker=True
            )
        self.env: Any = env
        self.u: Any = env.unwrapped
        # One fixed benchmark task object is needed once; afterwards placements come from the seed (not from the
        # 50 pre-sampled MT1 goals), as lerobot's MetaWorld environment does.
        selector: Any = env
        while not hasattr(selector, "toggle_sample_tasks_on_reset"):
            selector = selector.env
        self.u.set_task(selector.tasks[0])
        selector.toggle_sample_tasks_on_reset(False)
        self.model = self.u.model
        self.data = self.u.data
        rate = 1.0 / (float(self.model.opt.timestep) * int(self.u.frame_skip))
        if abs(rate - scene.scene.fps) > 1e-6:
            raise ConfigError(
                f"{source}: scene.fps: MetaWorld steps at {rate:g} Hz (timestep x frame skip); set fps: {rate:g}"
            )
        self.task_text = scene.task.instruction
        self._raw: npt.NDArray[np.float64] = np.zeros(39)
        self.initial = {}
        self.rig = named_camera_rig(self.model, self.data, list(scene.scene.cameras), scene.scene.render, source)
        self.spec = scene_spec(STATE_DIM, ACTION_DIM, scene.scene.cameras, scene.scene.fps, shapes=self.rig.shapes())

    # -- SimRollout ------------------------------------------------------------------------------------------
    def reset(self, seed: int) -> Observation:
        u = self.u
        u._freeze_rand_vec = False
        u.seeded_rand_vec = True
        u.seed(seed)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            raw, _ = self.env.reset()
        self._raw = np.asarray(raw, dtype=np.float64)
        self.t0 = float(self.data.time)
        self.initial = {
            "format": STATE_FORMAT,
            "suite": "metaworld",
            "task": self.params.task,
            "seed": seed,
            "rand_vec": np.asarray(u._last_rand_vec, dtype=np.float64).tolist(),
            "mujoco": mjstate.snapshot(self.model, self.data),
        }
        return self._observation()

    def reset_to(self, initial_state: dict[str, Any]) -> Observation:
        """Repeat the recorded seed's reset and check that it lands on the recorded state, bit for bit.

        MetaWorld derives each task's goal and success test from the seed's `rand_vec`, and writing a MuJoCo state
        back does not reproduce later steps exactly for every task (drawer-open drifts by ~1e-4), so a state is
        restored by reproducing it: a recorded state this MetaWorld does not reproduce from its seed is refused.
        """
        if initial_state.get("format") != STATE_FORMAT or initial_state.get("suite") != "metaworld":
            raise ConfigError(f"initial_state: format: not a MetaWorld state of format {STATE_FORMAT}")
        check_recorded_on(initial_state, "task", self.params.task)
        seed = int(initial_state.get("seed", 0))
        obs = self.reset(seed)
        recorded = np.asarray(initial_state.get("rand_vec", []), dtype=np.float64)
        if not np.array_equal(recorded, np.asarray(self.initial["rand_vec"])):
            raise ConfigError(
                f"initial_state: rand_vec: this MetaWorld draws another placement for seed {seed} "
                "(recorded with a different MetaWorld version?)"
            )
        if not mjstate.same_state(self.initial["mujoco"], initial_state.get("mujoco", {})):
            raise ConfigError(
                f"initial_state: mujoco: MetaWorld's reset with seed {seed} does not reproduce the recorded state"
            )
        return obs

    def step(self, action: npt.NDArray[np.float32]) -> StepResult:
        raw, reward, _, truncated, info = self.env.step(np.asarray(action, dtype=np.float32))
        self._raw = np.asarray(raw, dtype=np.float64)
        success = bool(info.get("success", 0.0))
        done = (success and self.params.terminate_on_success) or bool(truncated)
        return StepResult(self._observation(), reward=float(reward), success=success, terminated=done)

    # -- helpers ---------------------------------------------------------------------------------------------
    def _state(self) -> npt.NDArray[np.float32]:
        return self._raw[:STATE_DIM].astype(np.float32)

    def _observation(self) -> Observation:
        privileged: Privileged = {"suite": "metaworld", "task": self.params.task, "metaworld_obs": self._raw.copy()}
        return self.observe(self._state(), privileged)
