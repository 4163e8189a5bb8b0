"""The native tabletop scenes (`tabletop`, `tabletop_push`, `tabletop_pick_place`): any manifest arm on a table
with the objects and success criterion the scene YAML declares (schemas/tabletop.py), as a SimRollout.

Observation state, by the rSkill state contract's representation:
* `joint_positions_gripper`: arm joint positions (manifest order) + gripper opening state (0 open .. 1 closed)
* `joint_positions`: arm joint positions only
* `eef_pose_gripper`: end-effector site [x, y, z, qw, qx, qy, qz] (world frame; the quaternion's sign continuous
  within an episode, qw >= 0 on its first frame: producers/sim/quat_sign.py) + gripper state
* `eef_pose_gripper_width`: the same pose + the gripper's width in metres (the gap between the finger pads,
  finger_gap.py)
Actions: see controllers.py. `Observation.time` is simulation time since reset. With
`scene.observations.environment_state` the objects' poses (`object_poses` below) are recorded as
`observation.environment_state`.

`Observation.privileged` (ground truth for scripted experts and replay; never recorded), world frame, metres,
quaternions [qw, qx, qy, qz]:
* `object_poses`: {name: [x, y, z, qw, qx, qy, qz]} of every movable object (free joint; a drawer: its sliding
  body), the form replay compares with the initial state's `object_poses`; `fixed_poses`: the same of every
  fixed object (with `scene.observations.environment_goal` the goal's follows the objects' in
  `observation.environment_state`);
* `objects`: {name: {...}} for every object: `kind`, `movable`, `visual`, `pos`, `quat` (body origin), `size`
  (bounding-box extents in its own frame, x/y/z), `bottom` (origin height above its lowest point), `top_z`
  (world height of its top), `radius` (footprint radius around the origin); a drawer also `opening` (metres
  pulled out), `max_opening`, `handle_pos` (centre of the handle bar) and `open_dir` (unit vector it slides out
  along);
* `roles`: {role: object name}, e.g. `object`, `goal`, `support`, `drawer` (declared or derived from the
  success criterion: schemas/tabletop.py); `success`: the criterion as a dict (None: no criterion);
  `success_terms`: [(label, holds now)] of its leaves (`cube in goal`: success.py's `terms`);
  `workspace`: {x, y, z} ranges (z in world heights); `table_height`;
* the end effector: `ee_pos`, `ee_quat`, `gripper` (0 open .. 1 closed); `task`: the task label;
* the role `object` as `cube_pos`, `cube_quat`, `cube_size` (its height) and the role `goal` as `goal_pos`,
  `goal_radius` (its footprint half-size), the keys the `scripted-push` / `scripted-pick-place` experts read.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt
from pydantic import ValidationError

from openral_data import manifests
from openral_data.errors import ConfigError
from openral_data.producers.sim.contract import check_representations, scene_spec
from openral_data.producers.sim.initial_state import check_format, check_recorded_on
from openral_data.producers.sim.mujoco.assets import check_robosuite_assets, resolve_asset
from openral_data.producers.sim.mujoco.compose import ROBOT, compose
from openral_data.producers.sim.mujoco.controllers import (
    ACTION_REPRESENTATIONS,
    Controller,
    EefDeltaController,
    JointPositionController,
)
from openral_data.producers.sim.mujoco.finger_gap import FingerGap
from openral_data.producers.sim.mujoco.instruction import check_instruction, episode_instruction
from openral_data.producers.sim.mujoco.kinematics import F64, Arm, IKSolver
from openral_data.producers.sim.mujoco.placement import (
    DEFAULT_GAP,
    ROBOT_CLEARANCE,
    Extent,
    Placed,
    expand_clutter,
    extents,
    place,
    yaw_quat,
)
from openral_data.producers.sim.mujoco.randomize import DISTRACTOR_PREFIX, Randomizer, distractor_objects
from openral_data.producers.sim.mujoco.render import CameraRig
from openral_data.producers.sim.mujoco.rig_scene import RigScene
from openral_data.producers.sim.mujoco.success import holds, terms
from openral_data.producers.sim.params import parse_params
from openral_data.producers.sim.quat_sign import QuatTrack
from openral_data.schemas.base import format_validation_error
from openral_data.schemas.mujoco import MujocoRobotWiring, TabletopParams
from openral_data.schemas.robot import RobotManifest
from openral_data.schemas.rskill import RSkillManifest
from openral_data.schemas.scene import SimScene
from openral_data.schemas.tabletop import DrawerObject, check_layout, derived_roles
from openral_data.types import Observation, Privileged, StepResult

STATE_REPRESENTATIONS = ("joint_positions_gripper", "joint_positions", "eef_pose_gripper", "eef_pose_gripper_width")
STATE_FORMAT = 1


def load_wiring(robot: RobotManifest) -> tuple[MujocoRobotWiring, Path, Path | None, str]:
    """The robot's MuJoCo wiring and its MJCF files (no gripper MJCF: the arm's has its gripper); ConfigError
    naming the manifest field otherwise."""
    manifest = manifests.robot_file(robot.name)
    folder, source = manifest.parent, str(manifest)
    if robot.sim is None:
        raise ConfigError(f"{source}: sim: robot {robot.name!r} has no MuJoCo wiring (sim block)")
    try:
        wiring = MujocoRobotWiring.model_validate(robot.sim)
    except ValidationError as exc:
        raise ConfigError(format_validation_error(f"{source}: sim", exc)) from None
    if robot.assets.mjcf is None:
        raise ConfigError(f"{source}: assets.mjcf: needed by MuJoCo scenes")
    if robot.assets.mjcf.startswith("pkg://robosuite/"):
        check_robosuite_assets(source)
    arm = resolve_asset(robot.assets.mjcf, folder, f"{source}: assets.mjcf")
    grip = None
    if robot.assets.gripper_mjcf is not None:
        grip = resolve_asset(robot.assets.gripper_mjcf, folder, f"{source}: assets.gripper_mjcf")
    return wiring, arm, grip, source


class TabletopScene(RigScene):
    """A physics scene; one instance records many episodes (`reset(seed)` each), `close()` frees renderers.

    `task` is the task's label (`push`, `pick_place` for the scene types of those names; None for type
    `tabletop`: `params.task` or the scene id): recorded in the initial state, checked when one is restored."""

    def __init__(
        self,
        scene: SimScene,
        robot: RobotManifest,
        rskill: RSkillManifest,
        task: str | None,
        source: str = "scene",
        rskill_source: str = "rskill",
    ) -> None:
        self._check_scene(scene, rskill, task, source, rskill_source)
        wiring, arm_mjcf, grip_mjcf, robot_source = load_wiring(robot)
        if not wiring.tabletop:
            raise ConfigError(
                f"{robot_source}: sim.tabletop: robot {robot.name!r} is a twin only (record --hal {robot.name}); "
                "the tabletop scenes' workspace is out of its reach"
            )
        self._robot_source = robot_source
        self._build(scene, wiring, arm_mjcf, grip_mjcf, source)
        self._place(0)  # a layout that cannot be placed is refused now, not at some episode's reset
        self.n_substeps = max(1, round(1.0 / (scene.scene.fps * self.params.timestep)))
        self.ready_q = self._ready_posture(np.array(wiring.home))
        self._wire_control(scene, rskill.action_contract.representation)
        self._seed = 0
        self.initial = {}

    # -- setup -----------------------------------------------------------------------------------------------
    def _check_scene(
        self, scene: SimScene, rskill: RSkillManifest, task: str | None, source: str, rskill_source: str
    ) -> None:
        """The scene's params (their layout checked), the task they are, and the rSkill's representations."""
        self.params = parse_params(TabletopParams, scene, source)
        self._params_source = f"{source}: scene.params"
        check_layout(self.params, self.params.table_top, self._params_source)
        if task is not None and self.params.task not in (None, task):
            raise ConfigError(
                f"{self._params_source}.task: scene type {scene.scene.type!r} is the task {task!r}, "
                f"not {self.params.task!r}"
            )
        self.task_kind: str = task or self.params.task or scene.scene.id
        self.state_representation = rskill.state_contract.representation
        self._quat_track = QuatTrack()
        check_representations(
            rskill, rskill_source, "MuJoCo tabletop scenes", STATE_REPRESENTATIONS, ACTION_REPRESENTATIONS
        )

    def _build(
        self, scene: SimScene, wiring: MujocoRobotWiring, arm_mjcf: Path, grip_mjcf: Path | None, source: str
    ) -> None:
        """The composed model with the scene's objects, the arm's kinematics, and where each object lives in it."""
        area = self.params.workspace or self.params.table_top
        rz = self.params.randomize
        self.objects = expand_clutter(self.params, area) + distractor_objects(
            rz.distractors if rz is not None else None, area
        )
        self.composed = compose(
            robot_mjcf=arm_mjcf,
            gripper_mjcf=grip_mjcf,
            wiring=wiring,
            params=self.params,
            cameras=list(scene.scene.cameras),
            robot_source=self._robot_source,
            scene_source=source,
            objects=self.objects,
            textures=rz is not None and bool(rz.textures),
        )
        self.model = self.composed.model
        self.data = mujoco.MjData(self.model)
        self.randomizer = Randomizer(self.model, rz, self.objects, list(scene.scene.cameras), source)
        self.randomization: dict[str, Any] = {}  # the current episode's drawn values (its provenance)
        self._check_instruction(scene.task.instruction, source)
        self._nominal_extents = True
        self.arm = Arm.build(self.composed, wiring)
        self.ik = IKSolver(self.arm, rest=np.array(wiring.home))
        self.extents = extents(self.model, self.objects)
        self.roles = derived_roles(self.params)
        self._gap = self.params.clutter.gap if self.params.clutter is not None else DEFAULT_GAP
        m = self.model
        self._body = {o.name: int(m.body(o.name).id) for o in self.objects}
        self._free = {o.name: int(m.joint(o.name).qposadr[0]) for o in self.objects if o.is_movable}
        self._mocap = {o.name: int(m.body_mocapid[self._body[o.name]]) for o in self.objects if not o.is_movable}
        self._drawers = {
            o.name: (
                int(m.joint(o.name).qposadr[0]),
                int(m.body(f"{o.name}/drawer").id),
                int(m.site(f"{o.name}/handle").id),
            )
            for o in self.objects
            if isinstance(o, DrawerObject)
        }
        base = mujoco.MjData(self.model)
        mujoco.mj_kinematics(self.model, base)
        base_xy = np.array(base.xpos[self.model.body(ROBOT + wiring.root_body).id][:2], dtype=np.float64)
        self._keep_clear = [(base_xy, ROBOT_CLEARANCE)]

    def _wire_control(self, scene: SimScene, action_rep: str) -> None:
        """The controller for the action representation, the state's size (and finger gauge), the cameras and
        the spec the recording sees."""
        self.controller: Controller
        if action_rep == "joint_positions_gripper":
            self.controller = JointPositionController(self.arm)
        else:
            # the grasp site may go down to 5 mm above the table, never into it
            self.controller = EefDeltaController(self.arm, self.ik, min_height=self.params.table_height + 0.005)
        n = self.arm.n
        state_dim = {"joint_positions_gripper": n + 1, "joint_positions": n}.get(self.state_representation, 8)
        self.finger_gap: FingerGap | None = None
        if self.state_representation == "eef_pose_gripper_width":
            self.arm.hold(self.data, self.ready_q)
            mujoco.mj_forward(self.model, self.data)
            self.finger_gap = FingerGap(
                self.model, self.data, self.composed.gripper_joints, self.arm.site, self._robot_source
            )
        if scene.scene.observations.environment_state:
            goal = self.roles.get("goal")
            fixed_goal = (goal,) if scene.scene.observations.environment_goal and goal in self._mocap else ()
            self.environment_objects = (*self.object_names(), *fixed_goal)
        self.rig = CameraRig(self.model, list(scene.scene.cameras), scene.scene.render)
        self.spec = scene_spec(
            state_dim,
            self.controller.action_dim,
            scene.scene.cameras,
            scene.scene.fps,
            shapes=self.rig.shapes(),
            environment_objects=self.environment_objects,
        )

    def _ready_posture(self, home: F64) -> F64:
        """Arm posture with the grasp site at `ready_xy`, `ready_height` above the table, pointing down.

        The yaw about the vertical is the one the manifest's home posture has, so each arm keeps its natural
        wrist orientation. Deterministic: IK from the home posture.
        """
        d, a, p = self.data, self.arm, self.params
        d.qpos[a.qpos] = home
        mujoco.mj_kinematics(self.model, d)
        xmat = d.site_xmat[a.site].reshape(3, 3)
        x_axis = xmat[:, 0].copy()
        x_axis[2] = 0.0
        if np.linalg.norm(x_axis) < 1e-6:
            x_axis = np.array([1.0, 0.0, 0.0])
        x_axis /= np.linalg.norm(x_axis)
        z_axis = np.array([0.0, 0.0, -1.0])
        y_axis = np.cross(z_axis, x_axis)
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, np.stack([x_axis, y_axis, z_axis], axis=1).reshape(-1))
        pos = np.array([*p.ready_xy, p.table_height + p.ready_height], dtype=np.float64)
        q = self.ik.solve(d, pos, quat, iterations=300, max_step=0.1, q_start=home)
        perr, rerr = self.ik.pose_error(d, q, pos, quat)
        if perr > 0.01 or rerr > 0.05:
            raise ConfigError(
                f"{self._robot_source}: sim.home: the arm cannot reach the ready pose {pos.round(3).tolist()} "
                f"pointing down (error {perr:.3f} m, {rerr:.3f} rad; check sim.base_pos and scene.params)"
            )
        return q

    # -- SimRollout ------------------------------------------------------------------------------------------
    def reset(self, seed: int) -> Observation:
        self._seed = seed
        values = self.randomizer.draw(seed)
        self._randomize(values)
        parked = self.randomizer.parked(values)
        placed = self._place(seed, skip=set(parked))
        d, a = self.data, self.arm
        mujoco.mj_resetData(self.model, d)
        a.hold(d, self.ready_q)
        for k, name in enumerate(parked):
            c = self._free[name]
            d.qpos[c : c + 3] = self.randomizer.parked_pos(k)
            d.qpos[c + 3 : c + 7] = (1.0, 0.0, 0.0, 0.0)
        for name, p in placed.items():
            if name in self._free:
                c = self._free[name]
                d.qpos[c : c + 3] = p.pos
                d.qpos[c + 3 : c + 7] = yaw_quat(p.yaw)
            else:
                d.mocap_pos[self._mocap[name]] = p.pos
                d.mocap_quat[self._mocap[name]] = yaw_quat(p.yaw)
        return self._begin()

    def reset_to(self, initial_state: dict[str, Any]) -> Observation:
        """Restore exactly the state `initial_state()` described (for replay); the controller restarts too."""
        check_format(initial_state, STATE_FORMAT)
        check_recorded_on(initial_state, "task", self.task_kind)
        values = initial_state.get("randomization", {})
        if not isinstance(values, dict):
            raise ConfigError("initial_state: randomization: not a mapping")
        self._randomize(values)
        d = self.data
        mujoco.mj_resetData(self.model, d)
        try:
            for key in ("qpos", "qvel", "act", "ctrl", "mocap_pos", "mocap_quat"):
                target = getattr(d, key)
                value = np.asarray(initial_state[key], dtype=np.float64).reshape(target.shape)
                target[...] = value
        except (KeyError, ValueError) as exc:
            raise ConfigError(f"initial_state: does not fit this scene's model: {exc}") from None
        d.time = float(initial_state.get("time", 0.0))
        self._seed = int(initial_state.get("seed", 0))
        return self._begin()

    def step(self, action: npt.NDArray[np.float32]) -> StepResult:
        self.controller.apply(action, self.data)
        mujoco.mj_step(self.model, self.data, nstep=self.n_substeps)
        success = self.success()
        return StepResult(self._observation(), reward=float(success), success=success, terminated=success)

    # -- helpers ---------------------------------------------------------------------------------------------
    def _begin(self) -> Observation:
        """The episode starts from the state just written into `data`: derived quantities, the snapshot
        `initial_state()` returns, a restarted controller, and the first observation."""
        mujoco.mj_forward(self.model, self.data)
        self.initial = self._snapshot()
        self.controller.reset(self.data)
        self._quat_track.reset()
        return self._observation()

    def object_names(self) -> tuple[str, ...]:
        """The movable objects, in the order `observation.environment_state` lists them (`object_poses` keys);
        distractors (`randomize.distractors`, not every episode has them) are not among them."""
        return (*(n for n in self._free if not n.startswith(DISTRACTOR_PREFIX)), *self._drawers)

    def success(self) -> bool:
        return self.params.success is not None and holds(self.params.success, self)

    # -- the WorldView success.py reads ----------------------------------------------------------------------
    @property
    def table_height(self) -> float:
        return self.params.table_height

    def pos(self, name: str) -> F64:
        if name in self._mocap:
            return np.array(self.data.mocap_pos[self._mocap[name]], dtype=np.float64)
        return np.array(self.data.xpos[self._body[name]], dtype=np.float64)

    def quat(self, name: str) -> F64:
        if name in self._mocap:
            return np.array(self.data.mocap_quat[self._mocap[name]], dtype=np.float64)
        return np.array(self.data.xquat[self._body[name]], dtype=np.float64)

    def extent(self, name: str) -> Extent:
        return self.extents[name]

    def opening(self, name: str) -> float:
        return float(self.data.qpos[self._drawers[name][0]])

    # -- helpers ---------------------------------------------------------------------------------------------
    def _place(self, seed: int, skip: set[str] | None = None) -> dict[str, Placed]:
        rng = np.random.default_rng(seed)
        p = self.params
        objects = [o for o in self.objects if not skip or o.name not in skip]
        return place(objects, self.extents, p.table_height, rng, self._gap, self._params_source, self._keep_clear)

    def _check_instruction(self, instruction: str, source: str) -> None:
        """Keep the instruction, whose `{NAME.color}` each episode fills in (instruction.py), refusing one that
        would be false in some episode."""
        self.instruction = instruction
        r, rz = self.randomizer, self.params.randomize
        varies = rz if rz is not None and rz.enabled else None
        colors, textures = (varies.colors, varies.textures) if varies is not None else ([], [])
        check_instruction(instruction, r.rgba, r.names, colors, textures, source)
        self.task_text = episode_instruction(instruction, r.rgba)

    def _randomize(self, values: dict[str, Any]) -> None:
        """Write an episode's variation into the model (nominal first); sizes and masses changed mean new
        derived constants and, for sizes, new extents to place by."""
        changed = bool(values.get("physics") or values.get("distractors"))
        self.randomizer.apply(values)
        if changed or not self._nominal_extents:
            mujoco.mj_setConst(self.model, self.data)
            self.extents = extents(self.model, self.objects)
        self._nominal_extents = not changed
        self.randomization = values
        self.task_text = episode_instruction(self.instruction, self.randomizer.rgba)

    def cube_pos(self) -> F64:
        """The role `object`'s position (the cube of the push and pick-place scenes)."""
        return self.pos(self.roles["object"])

    def goal_pos(self) -> F64:
        return self.pos(self.roles["goal"])

    def fixed_poses(self) -> dict[str, F64]:
        """[x, y, z, qw, qx, qy, qz] of every fixed object (a goal region drawn from the seed, a support)."""
        d = self.data
        return {n: np.concatenate([d.mocap_pos[i], d.mocap_quat[i]]).astype(np.float64) for n, i in self._mocap.items()}

    def object_poses(self) -> dict[str, F64]:
        """[x, y, z, qw, qx, qy, qz] of every movable object (free joint; a drawer's sliding body)."""
        d = self.data
        out: dict[str, F64] = {}
        for name, c in self._free.items():
            out[name] = np.array(d.qpos[c : c + 7], dtype=np.float64)
        for name, (_, body, _) in self._drawers.items():
            out[name] = np.concatenate([d.xpos[body], d.xquat[body]]).astype(np.float64)
        return out

    def _object_info(self) -> dict[str, dict[str, Any]]:
        d = self.data
        out: dict[str, dict[str, Any]] = {}
        for obj in self.objects:
            e, pos = self.extents[obj.name], self.pos(obj.name)
            info: dict[str, Any] = {
                "kind": obj.kind,
                "movable": obj.is_movable,
                "visual": obj.visual,
                "pos": pos,
                "quat": self.quat(obj.name),
                "size": e.size,
                "bottom": e.bottom,
                "top_z": float(pos[2] + e.hi[2]),
                "radius": e.radius,
            }
            if isinstance(obj, DrawerObject):
                qadr, _, site = self._drawers[obj.name]
                rot = np.zeros(9)
                mujoco.mju_quat2Mat(rot, info["quat"])
                info.update(
                    opening=float(d.qpos[qadr]),
                    max_opening=obj.opening_limit,
                    handle_pos=np.array(d.site_xpos[site], dtype=np.float64),
                    open_dir=rot.reshape(3, 3) @ np.array([-1.0, 0.0, 0.0]),
                )
            out[obj.name] = info
        return out

    def _legacy(self) -> Privileged:
        """The keys the push and pick-place experts read, from the roles `object` and `goal`."""
        out: Privileged = {}
        target, goal = self.roles.get("object"), self.roles.get("goal")
        if target is not None:
            out["cube_pos"] = self.pos(target)
            c = self._free.get(target)
            out["cube_quat"] = self.data.qpos[c + 3 : c + 7].copy() if c is not None else self.quat(target)
            out["cube_size"] = float(self.extents[target].size[2])
        if goal is not None:
            e = self.extents[goal]
            out["goal_pos"] = self.pos(goal)
            out["goal_radius"] = float(e.hi[0]) if e.round else float(max(e.hi[0], e.hi[1]))
        return out

    def _snapshot(self) -> dict[str, Any]:
        d = self.data
        state: dict[str, Any] = {
            "format": STATE_FORMAT,
            "seed": self._seed,
            "task": self.task_kind,
            "time": float(d.time),
            "qpos": d.qpos.tolist(),
            "qvel": d.qvel.tolist(),
            "act": d.act.tolist(),
            "ctrl": d.ctrl.tolist(),
            "mocap_pos": d.mocap_pos.tolist(),
            "mocap_quat": d.mocap_quat.tolist(),
            "object_poses": {k: v.tolist() for k, v in self.object_poses().items()},
        }
        if self.randomization:
            state["randomization"] = self.randomization
        target, goal = self.roles.get("object"), self.roles.get("goal")
        if target in self._free:
            c = self._free[target]
            state["cube_pose"] = d.qpos[c : c + 7].tolist()
        if goal is not None:
            state["goal_pos"] = self.pos(goal).tolist()
        return state

    def _state(self) -> npt.NDArray[np.float32]:
        d, a = self.data, self.arm
        grip = a.gripper_state(d)
        if self.state_representation == "joint_positions":
            return np.array(d.qpos[a.qpos], dtype=np.float32)
        if self.state_representation == "joint_positions_gripper":
            return np.append(d.qpos[a.qpos], grip).astype(np.float32)
        pos, quat = a.ee_pose(d)
        last = grip if self.finger_gap is None else self.finger_gap.width(d)
        return np.concatenate([pos, self._quat_track(quat), [last]]).astype(np.float32)

    def _observation(self) -> Observation:
        d, p = self.data, self.params
        pos, quat = self.arm.ee_pose(d)
        ws = p.workspace or p.table_top
        z = p.workspace.z if p.workspace is not None else (0.0, 0.5)
        privileged: Privileged = {
            **self._legacy(),
            "ee_pos": pos,
            "ee_quat": quat,
            "gripper": self.arm.gripper_state(d),
            "table_height": p.table_height,
            "task": self.task_kind,
            "object_poses": self.object_poses(),  # the generic hook replay compares
            "fixed_poses": self.fixed_poses(),
            "objects": self._object_info(),
            "roles": dict(self.roles),
            "success": p.success.model_dump() if p.success is not None else None,
            "success_terms": terms(p.success, self) if p.success is not None else [],
            "workspace": {"x": ws.x, "y": ws.y, "z": (p.table_height + z[0], p.table_height + z[1])},
        }
        return self.observe(self._state(), privileged)
