"""Scripted experts for the MuJoCo tabletop scenes: `scripted-push` and `scripted-pick-place`.

They read the simulator's ground truth (`Observation.privileged`: cube, goal and end-effector poses) and emit
`delta_eef_gripper` actions [dx, dy, dz, drx, dry, drz, gripper] in the world frame; the scene's IK
controller (MuJoCo Jacobians) turns them into joint targets, so the same expert drives every arm.
Tunables come from the rSkill's `policy_extras` (`max_step`, `gain`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from openral_data.errors import ConfigError
from openral_data.schemas.rskill import RSkillManifest
from openral_data.types import Observation

F64 = npt.NDArray[np.float64]
TRAVEL = 0.1  # travel height of the grasp site above the table


def _yaw_of(quat: F64) -> float:
    """Heading of the frame's x axis projected on the table."""
    w, x, y, z = (float(v) for v in quat)
    return float(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))


def _wrap_quarter(angle: float) -> float:
    """An angle modulo 90 degrees, in [-45, 45) degrees: a cube looks the same every quarter turn."""
    return float((angle + np.pi / 4) % (np.pi / 2) - np.pi / 4)


class _Expert:
    def __init__(self, rskill: RSkillManifest) -> None:
        c = rskill.action_contract
        if c.representation != "delta_eef_gripper" or c.dim != 7:
            raise ConfigError(
                f"rskill {rskill.id}: action_contract: scripted experts emit delta_eef_gripper actions of dim 7, "
                f"got {c.representation} of dim {c.dim}"
            )
        extras = rskill.policy_extras
        self.max_step = float(extras.get("max_step", 0.02))  # type: ignore[arg-type]
        self.gain = float(extras.get("gain", 1.0))  # type: ignore[arg-type]
        self.phase = 0
        self.counter = 0

    def reset(self, seed: int) -> None:
        self.phase = 0
        self.counter = 0

    def close(self) -> None:
        pass

    @staticmethod
    def _truth(observation: Observation) -> tuple[dict[str, Any], F64, F64, F64, float, float]:
        """The scene's ground truth: the privileged dict, end-effector, cube and goal positions, the table height
        and half the cube's size."""
        p = observation.privileged
        if "cube_pos" not in p:
            raise ConfigError("scripted experts need a MuJoCo tabletop scene (no ground truth in the observation)")
        return p, p["ee_pos"], p["cube_pos"], p["goal_pos"], float(p["table_height"]), float(p["cube_size"]) / 2

    def _move(self, ee: F64, target: F64, max_step: float | None = None) -> F64:
        step = self.max_step if max_step is None else max_step
        delta = self.gain * (target - ee)
        norm = float(np.linalg.norm(delta))
        return delta if norm <= step else delta * (step / norm)

    @staticmethod
    def _action(dpos: F64, dyaw: float, gripper: float) -> npt.NDArray[np.float32]:
        return np.array([*dpos, 0.0, 0.0, dyaw, gripper], dtype=np.float32)


class ScriptedPush(_Expert):
    """Go behind the cube (seen from the goal), lower the closed gripper, push along cube -> goal; re-approach
    whenever the cube drifts off the pushing line."""

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        _, ee, cube, goal, h, half = self._truth(observation)
        to_goal = goal[:2] - cube[:2]
        dist = float(np.linalg.norm(to_goal))
        direction = to_goal / dist if dist > 1e-6 else np.array([1.0, 0.0])
        push_z = h + 0.022
        behind = cube[:2] - direction * (half + 0.035)
        rel = ee[:2] - cube[:2]
        along = float(rel @ direction)
        lateral = float(rel @ np.array([-direction[1], direction[0]]))
        if self.phase == 0:  # rise and travel behind the cube
            target = np.array([*behind, h + TRAVEL])
            if ee[2] < h + TRAVEL - 0.03 and np.linalg.norm(ee[:2] - behind) > 0.02:
                target = np.array([*ee[:2], h + TRAVEL])
            if np.linalg.norm(ee[:2] - behind) < 0.01:
                self.phase = 1
            return self._action(self._move(ee, target), 0.0, 1.0)
        if self.phase == 1:  # lower behind the cube
            target = np.array([*behind, push_z])
            if abs(ee[2] - push_z) < 0.01:
                self.phase = 2
            return self._action(self._move(ee, target), 0.0, 1.0)
        # push: advance along the line through the cube toward the goal, correcting sideways drift
        if abs(lateral) > 0.02 or along > -half + 0.005:
            self.phase = 0
            return self._action(self._move(ee, np.array([*ee[:2], h + TRAVEL])), 0.0, 1.0)
        aim = cube[:2] - direction * (half + 0.01) + direction * min(dist, 0.02)
        target = np.array([*aim, push_z])
        return self._action(self._move(ee, target, 0.012), 0.0, 1.0)


class ScriptedPickPlace(_Expert):
    """Above the cube (yaw aligned) -> down -> close -> lift -> above the pad -> down -> open -> rise."""

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        p, ee, cube, goal, h, half = self._truth(observation)
        yaw_err = _wrap_quarter(_yaw_of(p["cube_quat"]) - _yaw_of(p["ee_quat"]))
        dyaw = float(np.clip(0.5 * yaw_err, -0.1, 0.1))
        carry_z = h + 0.15
        place_z = h + 0.02 + half + 0.012  # pad top + cube half + a little drop
        if self.phase == 0:  # above the cube, open, aligned
            target = np.array([*cube[:2], h + TRAVEL])
            if np.linalg.norm(ee[:2] - cube[:2]) < 0.008 and abs(yaw_err) < 0.04 and abs(ee[2] - target[2]) < 0.03:
                self.phase = 1
            return self._action(self._move(ee, target), dyaw, 0.0)
        if self.phase == 1:  # descend around the cube
            target = np.array([*cube[:2], h + half])
            if abs(ee[2] - target[2]) < 0.006:
                self.phase, self.counter = 2, 0
            return self._action(self._move(ee, target), dyaw, 0.0)
        if self.phase == 2:  # close
            self.counter += 1
            if self.counter >= 8:
                self.phase = 3
            return self._action(np.zeros(3), 0.0, 1.0)
        if self.phase == 3:  # lift; the cube must come along
            target = np.array([*ee[:2], carry_z])
            if ee[2] > h + 0.08 and cube[2] < h + half + 0.02:
                self.phase = 0  # dropped it: start over
                return self._action(np.zeros(3), 0.0, 0.0)
            if ee[2] > carry_z - 0.02:
                self.phase = 4
            return self._action(self._move(ee, target), 0.0, 1.0)
        if self.phase == 4:  # carry over the pad
            target = np.array([*goal[:2], carry_z])
            if cube[2] < h + half + 0.02:
                self.phase = 0
                return self._action(np.zeros(3), 0.0, 0.0)
            if np.linalg.norm(cube[:2] - goal[:2]) < 0.01:
                self.phase = 5
            offset = ee[:2] - cube[:2]  # keep the cube (not the hand) centred over the pad
            return self._action(self._move(ee, np.array([*(goal[:2] + offset), carry_z])), 0.0, 1.0)
        if self.phase == 5:  # lower onto the pad
            offset = ee[:2] - cube[:2]
            target = np.array([*(goal[:2] + offset), place_z])
            if abs(ee[2] - place_z) < 0.006:
                self.phase, self.counter = 6, 0
            return self._action(self._move(ee, target, 0.012), 0.0, 1.0)
        # release and rise
        self.counter += 1
        target = np.array([*ee[:2], h + TRAVEL if self.counter > 6 else ee[2]])
        return self._action(self._move(ee, target), 0.0, 0.0)
