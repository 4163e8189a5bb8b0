"""`tabletop_push` / `tabletop_pick_place`: any manifest arm on a table with a cube, as a SimRollout.

Observation state, by the rSkill state contract's representation:
* `joint_positions_gripper`: arm joint positions (manifest order) + gripper opening state (0 open .. 1 closed)
* `joint_positions`: arm joint positions only
* `eef_pose_gripper`: end-effector site [x, y, z, qw, qx, qy, qz] (world frame, qw >= 0) + gripper state
* `eef_pose_gripper_width`: the same pose + the gripper's width in metres (the gap between the finger pads,
  finger_gap.py)
Actions: see controllers.py. `Observation.time` is simulation time since reset; `Observation.privileged`
holds ground truth (cube, goal, end effector) for scripted experts and is never recorded; with
`scene.observations.environment_state` the objects' poses are recorded as `observation.environment_state`.
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
from openral_data.producers.sim.mujoco.compose import CUBE, GOAL, compose
from openral_data.producers.sim.mujoco.controllers import (
    ACTION_REPRESENTATIONS,
    Controller,
    EefDeltaController,
    JointPositionController,
)
from openral_data.producers.sim.mujoco.finger_gap import FingerGap
from openral_data.producers.sim.mujoco.kinematics import F64, Arm, IKSolver
from openral_data.producers.sim.mujoco.render import CameraRig
from openral_data.producers.sim.mujoco.rig_scene import RigScene
from openral_data.producers.sim.mujoco.tasks import TaskKind, is_success, sample_placement
from openral_data.producers.sim.params import parse_params
from openral_data.schemas.base import format_validation_error
from openral_data.schemas.mujoco import MujocoRobotWiring, TabletopParams
from openral_data.schemas.robot import RobotManifest
from openral_data.schemas.rskill import RSkillManifest
from openral_data.schemas.scene import SimScene
from openral_data.types import Observation, StepResult

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
    """A physics scene; one instance records many episodes (`reset(seed)` each), `close()` frees renderers."""

    def __init__(
        self,
        scene: SimScene,
        robot: RobotManifest,
        rskill: RSkillManifest,
        task: TaskKind,
        source: str = "scene",
        rskill_source: str = "rskill",
    ) -> None:
        self.params = parse_params(TabletopParams, scene, source)
        self.task_kind: TaskKind = task
        self.state_representation = rskill.state_contract.representation
        action_rep = rskill.action_contract.representation
        check_representations(
            rskill, rskill_source, "MuJoCo tabletop scenes", STATE_REPRESENTATIONS, ACTION_REPRESENTATIONS
        )
        wiring, arm_mjcf, grip_mjcf, robot_source = load_wiring(robot)
        if not wiring.tabletop:
            raise ConfigError(
                f"{robot_source}: sim.tabletop: robot {robot.name!r} is a twin only (record --hal {robot.name}); "
                "the tabletop scenes' workspace is out of its reach"
            )
        self._robot_source = robot_source
        self.composed = compose(
            robot_mjcf=arm_mjcf,
            gripper_mjcf=grip_mjcf,
            wiring=wiring,
            params=self.params,
            cameras=list(scene.scene.cameras),
            task=task,
            robot_source=robot_source,
            scene_source=source,
        )
        self.model = self.composed.model
        self.data = mujoco.MjData(self.model)
        self.arm = Arm.build(self.composed, wiring)
        self.ik = IKSolver(self.arm, rest=np.array(wiring.home))
        self._cube_qpos = int(self.model.joint(CUBE).qposadr[0])
        self._cube_body = int(self.model.body(CUBE).id)
        self._goal_mocap = int(self.model.body_mocapid[self.model.body(GOAL).id])
        self.n_substeps = max(1, round(1.0 / (scene.scene.fps * self.params.timestep)))
        self.ready_q = self._ready_posture(np.array(wiring.home))
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
                self.model, self.data, self.composed.gripper_joints, self.arm.site, robot_source
            )
        self.task_text = scene.task.instruction
        if scene.scene.observations.environment_state:
            self.environment_objects = self.object_names()
        self.rig = CameraRig(self.model, list(scene.scene.cameras), scene.scene.render)
        self.spec = scene_spec(
            state_dim,
            self.controller.action_dim,
            scene.scene.cameras,
            scene.scene.fps,
            shapes=self.rig.shapes(),
            environment_objects=self.environment_objects,
        )
        self._seed = 0
        self.initial = {}

    # -- setup -----------------------------------------------------------------------------------------------
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
        placement = sample_placement(self.task_kind, self.params, np.random.default_rng(seed))
        d, a = self.data, self.arm
        mujoco.mj_resetData(self.model, d)
        a.hold(d, self.ready_q)
        c = self._cube_qpos
        d.qpos[c : c + 3] = placement.cube_pos
        d.qpos[c + 3 : c + 7] = [np.cos(placement.cube_yaw / 2), 0.0, 0.0, np.sin(placement.cube_yaw / 2)]
        d.mocap_pos[self._goal_mocap] = placement.goal_pos
        d.mocap_quat[self._goal_mocap] = [1.0, 0.0, 0.0, 0.0]
        return self._begin()

    def reset_to(self, initial_state: dict[str, Any]) -> Observation:
        """Restore exactly the state `initial_state()` described (for replay); the controller restarts too."""
        check_format(initial_state, STATE_FORMAT)
        check_recorded_on(initial_state, "task", self.task_kind)
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
        return self._observation()

    def object_names(self) -> tuple[str, ...]:
        """The movable objects, in the order `observation.environment_state` lists them (`object_poses` keys)."""
        return (CUBE,)

    def success(self) -> bool:
        return is_success(self.task_kind, self.params, self.cube_pos(), self.goal_pos())

    def cube_pos(self) -> F64:
        return np.array(self.data.xpos[self._cube_body], dtype=np.float64)

    def goal_pos(self) -> F64:
        return np.array(self.data.mocap_pos[self._goal_mocap], dtype=np.float64)

    def _snapshot(self) -> dict[str, Any]:
        d = self.data
        c = self._cube_qpos
        return {
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
            "cube_pose": d.qpos[c : c + 7].tolist(),
            "goal_pos": d.mocap_pos[self._goal_mocap].tolist(),
            "object_poses": {"cube": d.qpos[c : c + 7].tolist()},
        }

    def _state(self) -> npt.NDArray[np.float32]:
        d, a = self.data, self.arm
        grip = a.gripper_state(d)
        if self.state_representation == "joint_positions":
            return np.array(d.qpos[a.qpos], dtype=np.float32)
        if self.state_representation == "joint_positions_gripper":
            return np.append(d.qpos[a.qpos], grip).astype(np.float32)
        pos, quat = a.ee_pose(d)
        last = grip if self.finger_gap is None else self.finger_gap.width(d)
        return np.concatenate([pos, quat, [last]]).astype(np.float32)

    def _observation(self) -> Observation:
        d = self.data
        pos, quat = self.arm.ee_pose(d)
        c = self._cube_qpos
        privileged: dict[str, Any] = {
            "cube_pos": self.cube_pos(),
            "cube_quat": d.qpos[c + 3 : c + 7].copy(),
            "goal_pos": self.goal_pos(),
            "ee_pos": pos,
            "ee_quat": quat,
            "gripper": self.arm.gripper_state(d),
            "table_height": self.params.table_height,
            "cube_size": self.params.cube_size,
            "goal_radius": self.params.goal_radius,
            "task": self.task_kind,
            "object_poses": {"cube": d.qpos[c : c + 7].copy()},  # the generic hook replay compares
        }
        return self.observe(self._state(), privileged)
