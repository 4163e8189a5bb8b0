"""The robot of any manifest with a `sim:` block, on the standard table, in the manifest's own units.

`Twin` is the core the real-time twin HAL (producers/hal/robots/twin.py) and the `mujoco_twin` scene share: the composed
world (`compose`, the manifest's wiring, no per-robot code), the arm's position servos, and the conversion
between the manifest's units (`sim.units`, e.g. the SO arm's degrees and 0..100 gripper) and the MJCF's.

`TwinScene` is that robot as a SimRollout stepped in simulation time (`fps` control steps per second): what
`replay` rebuilds for a `record --hal` recording (real arm or twin). An episode starts from the robot state the
recording began with (`initial_state()["state"]`, manifest units); the twin has no task, so it never reports
success or terminates.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from openral_data.errors import ConfigError
from openral_data.producers.sim.contract import check_representations, scene_spec
from openral_data.producers.sim.mujoco.compose import ROBOT, compose
from openral_data.producers.sim.mujoco.controllers import JointPositionController
from openral_data.producers.sim.mujoco.kinematics import F64, Arm
from openral_data.producers.sim.mujoco.render import CameraRig
from openral_data.producers.sim.mujoco.rig_scene import RigScene
from openral_data.producers.sim.mujoco.scene import load_wiring
from openral_data.producers.sim.mujoco.units import UnitMap
from openral_data.schemas.mujoco import TabletopParams
from openral_data.schemas.robot import RobotManifest
from openral_data.schemas.rskill import RSkillManifest
from openral_data.schemas.scene import SceneCamera, SimScene
from openral_data.types import Observation, StepResult

F32 = npt.NDArray[np.float32]


class Twin:
    """The composed world and the arm in it; every vector in or out is in the manifest's units and order."""

    def __init__(self, robot: RobotManifest, cameras: list[SceneCamera]) -> None:
        wiring, arm_mjcf, grip_mjcf, source = load_wiring(robot)
        self.source = source
        self.params = TabletopParams()
        composed = compose(
            robot_mjcf=arm_mjcf,
            gripper_mjcf=grip_mjcf,
            wiring=wiring,
            params=self.params,
            cameras=cameras,
            robot_source=source,
            scene_source=source,
        )
        self.model = composed.model
        self.arm = Arm.build(composed, wiring)
        self.controller = JointPositionController(self.arm)
        self.units = UnitMap(wiring.units)
        n = self.arm.n
        if robot.action.dim != n + 1:
            raise ConfigError(f"{source}: action.dim: the twin takes {n} arm joint targets + gripper ({n + 1})")
        if robot.observation.state.dim not in (n, n + 1):
            raise ConfigError(f"{source}: observation.state.dim: the twin reports {n} joints (+ gripper)")
        self.state_dim = robot.observation.state.dim
        self.home = np.array(wiring.home, dtype=np.float64)
        self.base_body = int(self.model.body(ROBOT + wiring.root_body).id)

    def hold_home(self, data: mujoco.MjData) -> None:
        mujoco.mj_resetData(self.model, data)
        self.arm.hold(data, self.home)
        mujoco.mj_forward(self.model, data)

    def place(self, data: mujoco.MjData, state: npt.ArrayLike) -> None:
        """Put the robot at `state` (manifest units; no gripper entry: open), commanded to stay there."""
        a, u = self.arm, self.units
        s = np.asarray(state, dtype=np.float64)
        mujoco.mj_resetData(self.model, data)
        a.hold(data, np.clip(u.arm_to_sim(s[: a.n]), a.lower, a.upper))
        if s.shape[0] > a.n:
            closure = float(np.clip(u.gripper_to_sim(s[a.n]), 0.0, 1.0))
            data.qpos[a.grip_qpos] = a.grip_joint_open + closure * (a.grip_joint_closed - a.grip_joint_open)
            data.ctrl[a.grip_act] = a.gripper_ctrl(closure)
        mujoco.mj_forward(self.model, data)

    def command(self, data: mujoco.MjData, action: npt.ArrayLike) -> None:
        """Servo targets for `action` (manifest units: n arm joints + gripper)."""
        a, u = self.arm, self.units
        act = np.asarray(action, dtype=np.float64)
        sim = np.append(u.arm_to_sim(act[: a.n]), u.gripper_to_sim(act[a.n]))
        self.controller.apply(sim.astype(np.float32), data)

    def state(self, data: mujoco.MjData) -> F32:
        a, u = self.arm, self.units
        q = u.arm_from_sim(data.qpos[a.qpos])
        if self.state_dim == a.n + 1:
            q = np.append(q, u.gripper_from_sim(a.gripper_state(data)))
        return q.astype(np.float32)

    def forward_kinematics(self, data: mujoco.MjData, scratch: mujoco.MjData, q: F64) -> F64:
        """End-effector site position for the arm joint targets in `q` (manifest units), base frame."""
        a = self.arm
        scratch.qpos[:] = data.qpos
        scratch.qpos[a.qpos] = np.clip(self.units.arm_to_sim(q[: a.n]), a.lower, a.upper)
        mujoco.mj_kinematics(self.model, scratch)
        ee: F64 = np.array(scratch.site_xpos[a.site], dtype=np.float64)
        return ee - np.array(scratch.xpos[self.base_body], dtype=np.float64)


class TwinScene(RigScene):
    """`scene.type: mujoco_twin`: the twin stepped `1 / fps` seconds per action, from a recorded start."""

    def __init__(self, scene: SimScene, robot: RobotManifest, rskill: RSkillManifest, source: str = "scene") -> None:
        rskill_source = f"rskill {rskill.id}"
        check_representations(
            rskill, rskill_source, "the MuJoCo twin", ("joint_positions_gripper", "joint_positions"),
            ("joint_positions_gripper",),
        )  # fmt: skip
        cameras = list(scene.scene.cameras)
        self.twin = Twin(robot, cameras)
        self.model = self.twin.model
        self.data = mujoco.MjData(self.model)
        self.n_substeps = max(1, round(1.0 / (scene.scene.fps * self.twin.params.timestep)))
        self.task_text = scene.task.instruction
        self.spec = scene_spec(self.twin.state_dim, self.twin.arm.n + 1, cameras, scene.scene.fps)
        self.rig = CameraRig(self.model, cameras, scene.scene.render)
        self.initial = {}

    def reset(self, seed: int) -> Observation:
        self.twin.hold_home(self.data)
        return self._begin()

    def reset_to(self, initial_state: dict[str, Any]) -> Observation:
        state = initial_state.get("state")
        if not isinstance(state, list) or len(state) != self.twin.state_dim:
            raise ConfigError(
                f"initial_state: state: the robot's starting state ({self.twin.state_dim} numbers) was not recorded "
                "(a recording made before openral-data recorded it), so the twin cannot start where the robot did"
            )
        self.twin.place(self.data, state)
        return self._begin()

    def step(self, action: npt.NDArray[np.float32]) -> StepResult:
        self.twin.command(self.data, action)
        mujoco.mj_step(self.model, self.data, nstep=self.n_substeps)
        return StepResult(self._observation(), reward=0.0, success=False, terminated=False)

    def _begin(self) -> Observation:
        self.initial = {"hal": "mujoco_twin", "state": self.twin.state(self.data).tolist()}
        return self._observation()

    def _observation(self) -> Observation:
        return self.observe(self.twin.state(self.data), {})
