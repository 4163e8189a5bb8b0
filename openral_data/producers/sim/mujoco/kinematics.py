"""The arm as MuJoCo sees it (addresses of joints, actuators, the end-effector site) and damped least-squares
inverse kinematics on MuJoCo's own Jacobians (`mj_jacSite`), computed on a scratch MjData."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import numpy.typing as npt

from openral_data.producers.sim.mujoco.compose import Composed
from openral_data.schemas.mujoco import MujocoRobotWiring

F64 = npt.NDArray[np.float64]


def _joint_actuator(model: mujoco.MjModel, joint_name: str) -> int:
    jid = model.joint(joint_name).id
    for a in range(model.nu):
        if model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT and model.actuator_trnid[a, 0] == jid:
            return a
    raise ValueError(f"no actuator drives joint {joint_name}")


@dataclass
class Arm:
    """Indices into MjModel/MjData for the manifest's arm, gripper and end-effector site."""

    model: mujoco.MjModel
    qpos: npt.NDArray[np.int64]
    dof: npt.NDArray[np.int64]
    act: npt.NDArray[np.int64]
    lower: F64
    upper: F64
    grip_act: npt.NDArray[np.int64]
    grip_open: F64
    grip_closed: F64
    grip_qpos: npt.NDArray[np.int64]
    grip_joint_open: F64
    grip_joint_closed: F64
    site: int

    @classmethod
    def build(cls, composed: Composed, wiring: MujocoRobotWiring) -> Arm:
        m = composed.model
        qpos = np.array([m.joint(j).qposadr[0] for j in composed.arm_joints], dtype=np.int64)
        dof = np.array([m.joint(j).dofadr[0] for j in composed.arm_joints], dtype=np.int64)
        act = np.array([_joint_actuator(m, j) for j in composed.arm_joints], dtype=np.int64)
        jids = [m.joint(j).id for j in composed.arm_joints]
        limited = np.array([bool(m.jnt_limited[j]) for j in jids])
        rng = np.array([m.jnt_range[j] for j in jids], dtype=np.float64)
        lower = np.where(limited, rng[:, 0], -np.inf)
        upper = np.where(limited, rng[:, 1], np.inf)
        g = wiring.gripper
        return cls(
            model=m,
            qpos=qpos,
            dof=dof,
            act=act,
            lower=lower,
            upper=upper,
            grip_act=np.array([m.actuator(a).id for a in composed.gripper_actuators], dtype=np.int64),
            grip_open=np.array(g.open, dtype=np.float64),
            grip_closed=np.array(g.closed, dtype=np.float64),
            grip_qpos=np.array([m.joint(j).qposadr[0] for j in composed.gripper_joints], dtype=np.int64),
            grip_joint_open=np.array(g.joint_open, dtype=np.float64),
            grip_joint_closed=np.array(g.joint_closed, dtype=np.float64),
            site=m.site(composed.ee_site).id,
        )

    @property
    def n(self) -> int:
        return len(self.qpos)

    def hold(self, data: mujoco.MjData, q: F64) -> None:
        """Put the arm at posture `q` with the gripper open, its actuators commanded to stay there."""
        data.qpos[self.qpos] = q
        data.qpos[self.grip_qpos] = self.grip_joint_open
        data.ctrl[self.act] = q
        data.ctrl[self.grip_act] = self.gripper_ctrl(0.0)

    def gripper_ctrl(self, g: float) -> F64:
        """Actuator controls for the normalised gripper command g (0 = open, 1 = closed)."""
        c = float(np.clip(g, 0.0, 1.0))
        return self.grip_open + c * (self.grip_closed - self.grip_open)

    def gripper_state(self, data: mujoco.MjData) -> float:
        span = self.grip_joint_closed - self.grip_joint_open
        frac = (data.qpos[self.grip_qpos] - self.grip_joint_open) / np.where(span == 0, 1.0, span)
        return float(np.clip(frac.mean(), 0.0, 1.0))

    def ee_pose(self, data: mujoco.MjData) -> tuple[F64, F64]:
        """End-effector site position and orientation (w, x, y, z; w >= 0) in the world frame."""
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, data.site_xmat[self.site])
        if quat[0] < 0:
            quat = -quat
        return np.array(data.site_xpos[self.site], dtype=np.float64), quat


def orientation_error(target_quat: F64, current_quat: F64) -> F64:
    """Rotation vector (world frame) taking `current_quat` to `target_quat`."""
    conj = np.zeros(4)
    mujoco.mju_negQuat(conj, current_quat)
    diff = np.zeros(4)
    mujoco.mju_mulQuat(diff, target_quat, conj)
    vel = np.zeros(3)
    mujoco.mju_quat2Vel(vel, diff, 1.0)
    return vel


class IKSolver:
    """Damped least squares on the site Jacobian, with a pull toward a rest posture in the null space."""

    def __init__(self, arm: Arm, rest: F64, damping: float = 0.05, null_gain: float = 0.05) -> None:
        self.arm = arm
        self.rest = np.asarray(rest, dtype=np.float64)
        self.damping = damping
        self.null_gain = null_gain
        self._data = mujoco.MjData(arm.model)
        self._jacp = np.zeros((3, arm.model.nv))
        self._jacr = np.zeros((3, arm.model.nv))

    def solve(
        self,
        data: mujoco.MjData,
        target_pos: F64,
        target_quat: F64,
        iterations: int = 3,
        max_step: float = 0.25,
        q_start: F64 | None = None,
    ) -> F64:
        """Arm joint positions bringing the site toward the target pose, starting from `data`'s posture."""
        a, s = self.arm, self._data
        s.qpos[:] = data.qpos
        if q_start is not None:
            s.qpos[a.qpos] = q_start
        q: F64 = np.array(s.qpos[a.qpos], dtype=np.float64)
        eye = np.eye(a.n)
        for _ in range(iterations):
            mujoco.mj_kinematics(a.model, s)
            mujoco.mj_comPos(a.model, s)
            pos, quat = a.ee_pose(s)
            err = np.concatenate([target_pos - pos, orientation_error(target_quat, quat)])
            mujoco.mj_jacSite(a.model, s, self._jacp, self._jacr, a.site)
            jac = np.vstack([self._jacp[:, a.dof], self._jacr[:, a.dof]])
            jjt = jac @ jac.T + (self.damping**2) * np.eye(6)
            dq = jac.T @ np.linalg.solve(jjt, err)
            pinv = np.linalg.pinv(jac)  # the exact null space: the pull to `rest` does not move the site
            dq += (eye - pinv @ jac) @ (self.null_gain * (self.rest - q))
            norm = float(np.abs(dq).max())
            if norm > max_step:
                dq *= max_step / norm
            q = np.clip(q + dq, a.lower, a.upper)
            s.qpos[a.qpos] = q
        return q

    def pose_error(self, data: mujoco.MjData, q: F64, target_pos: F64, target_quat: F64) -> tuple[float, float]:
        s = self._data
        s.qpos[:] = data.qpos
        s.qpos[self.arm.qpos] = q
        mujoco.mj_kinematics(self.arm.model, s)
        pos, quat = self.arm.ee_pose(s)
        return float(np.linalg.norm(target_pos - pos)), float(np.linalg.norm(orientation_error(target_quat, quat)))
