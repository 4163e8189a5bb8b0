"""Action -> actuator controls, chosen by the rSkill action contract's representation.

* `joint_positions_gripper` (n arm joints + 1): arm joint targets (radians, clipped to the joint limits)
  for the position servos, plus the normalised gripper command (0 = open, 1 = closed).
* `delta_eef_gripper` (7): [dx, dy, dz, drx, dry, drz, gripper] — a translation (metres) and a rotation
  vector (radians), both in the world frame. The position target is the previous target + the translation
  (kept above `min_height`, and ahead of the actual position by at most the larger of this step's translation
  and `max_lead_translation`, so blocked or lagging motion does not wind up) and the orientation target
  accumulates the rotations (within `max_lead_rotation` of the actual orientation): a zero action holds the pose
  instead of following whatever the arm lagged behind by (5 mm/s of drift when the target was re-read). IK
  (MuJoCo Jacobians) turns the target pose into servo targets. Deltas are clipped to `max_translation` /
  `max_rotation`.

The dataset stores the action exactly as the policy emitted it; clipping happens here, in the scene.
"""

from __future__ import annotations

from typing import Protocol

import mujoco
import numpy as np
import numpy.typing as npt

from openral_data.producers.sim.mujoco.kinematics import F64, Arm, IKSolver, orientation_error

ACTION_REPRESENTATIONS = ("joint_positions_gripper", "delta_eef_gripper")


class Controller(Protocol):
    action_dim: int

    def reset(self, data: mujoco.MjData) -> None: ...

    def apply(self, action: npt.NDArray[np.float32], data: mujoco.MjData) -> None: ...


class JointPositionController:
    def __init__(self, arm: Arm) -> None:
        self.arm = arm
        self.action_dim = arm.n + 1

    def reset(self, data: mujoco.MjData) -> None:
        pass

    def apply(self, action: npt.NDArray[np.float32], data: mujoco.MjData) -> None:
        a = self.arm
        q = np.clip(action[: a.n].astype(np.float64), a.lower, a.upper)
        data.ctrl[a.act] = q
        data.ctrl[a.grip_act] = a.gripper_ctrl(float(action[a.n]))


class EefDeltaController:
    action_dim = 7

    def __init__(
        self,
        arm: Arm,
        ik: IKSolver,
        *,
        min_height: float,
        max_translation: float = 0.05,
        max_rotation: float = 0.3,
        max_lead_rotation: float = 0.3,
        max_lead_translation: float = 0.01,
    ) -> None:
        self.arm = arm
        self.ik = ik
        self.min_height = min_height
        self.max_translation = max_translation
        self.max_rotation = max_rotation
        self.max_lead_rotation = max_lead_rotation
        self.max_lead_translation = max_lead_translation
        self.target_pos: F64 = np.zeros(3)
        self.target_quat: F64 = np.array([1.0, 0.0, 0.0, 0.0])

    def reset(self, data: mujoco.MjData) -> None:
        self.target_pos, self.target_quat = self.arm.ee_pose(data)

    def apply(self, action: npt.NDArray[np.float32], data: mujoco.MjData) -> None:
        a = self.arm
        act = action.astype(np.float64)
        dpos = np.clip(act[:3], -self.max_translation, self.max_translation)
        drot = act[3:6]
        angle = float(np.linalg.norm(drot))
        if angle > self.max_rotation:
            drot = drot * (self.max_rotation / angle)
        pos, quat = a.ee_pose(data)
        target = self.target_pos + dpos  # from the held target, not the sagging pose: a zero delta holds the pose
        lead = target - pos  # the target leads the site by at most this step's delta or max_lead_translation
        lead_len, cap = float(np.linalg.norm(lead)), max(self.max_lead_translation, float(np.linalg.norm(dpos)))
        if lead_len > cap:
            target = pos + lead * (cap / lead_len)
        target[2] = max(target[2], self.min_height)
        self.target_pos = target
        rot = np.zeros(4)
        axis = drot / angle if angle > 1e-12 else np.array([0.0, 0.0, 1.0])
        mujoco.mju_axisAngle2Quat(rot, axis, min(angle, self.max_rotation))
        goal = np.zeros(4)
        mujoco.mju_mulQuat(goal, rot, self.target_quat)
        mujoco.mju_normalize4(goal)
        lead = orientation_error(goal, quat)  # keep the orientation target within max_lead_rotation
        lead_angle = float(np.linalg.norm(lead))
        if lead_angle > self.max_lead_rotation:
            back = np.zeros(4)
            mujoco.mju_axisAngle2Quat(back, lead / lead_angle, self.max_lead_rotation)
            mujoco.mju_mulQuat(goal, back, quat)
        self.target_quat = goal
        q = self.ik.solve(data, self.target_pos, self.target_quat, q_start=data.ctrl[a.act].copy())
        data.ctrl[a.act] = q
        data.ctrl[a.grip_act] = a.gripper_ctrl(float(act[6]))
