"""Scripted experts for the MuJoCo tabletop scenes: `scripted-push`, `scripted-pick-place` (also stack and
place-on: an object onto a support), `scripted-pick` (pick an object, e.g. out of clutter, and lift it) and
`scripted-open-drawer`.

They read the simulator's ground truth (`Observation.privileged`: object poses and sizes, roles, end-effector
pose) and emit `delta_eef_gripper` actions [dx, dy, dz, drx, dry, drz, gripper] in the world frame; the scene's
IK controller (MuJoCo Jacobians) turns them into joint targets, so the same expert drives every arm. Which object
is which comes from `privileged["roles"]` (`object`, `support`/`goal`, `drawer`: derived from the scene's
success criterion or declared in its YAML). The moves are the primitives of policies/motion.py. Tunables come
from the rSkill's `policy_extras` (`max_step`, `gain`).
"""

from __future__ import annotations

import numpy as np

from openral_data.errors import ConfigError
from openral_data.policies.motion import CARRY, TRAVEL, Action, Mover, Truth, action, wrap
from openral_data.producers.sim.mujoco.placement import yaw_of
from openral_data.schemas.rskill import RSkillManifest
from openral_data.types import Observation

QUARTER, HALF = np.pi / 2, np.pi  # a box looks the same every quarter turn; a handle every half turn


class _Expert:
    def __init__(self, rskill: RSkillManifest) -> None:
        c = rskill.action_contract
        if c.representation != "delta_eef_gripper" or c.dim != 7:
            raise ConfigError(
                f"rskill {rskill.id}: action_contract: scripted experts emit delta_eef_gripper actions of dim 7, "
                f"got {c.representation} of dim {c.dim}"
            )
        extras = rskill.policy_extras
        self.mover = Mover(
            max_step=float(extras.get("max_step", 0.02)),  # type: ignore[arg-type]
            gain=float(extras.get("gain", 1.0)),  # type: ignore[arg-type]
        )
        self.phase = 0
        self.counter = 0

    def reset(self, seed: int) -> None:
        self.phase = 0
        self.counter = 0

    def close(self) -> None:
        pass

    def _goto(self, phase: int) -> None:
        self.phase, self.counter = phase, 0


class ScriptedPush(_Expert):
    """Go behind the object (seen from the goal), lower the closed gripper, push along object -> goal;
    re-approach whenever the object drifts off the pushing line."""

    def step(self, observation: Observation, instruction: str) -> Action:
        t = Truth.of(observation)
        name = t.role("object")
        cube, goal, h, ee = t.pos(name), t.pos(t.role("goal")), t.table, t.ee
        half = float(t.info(name)["size"][2]) / 2
        move = self.mover.delta
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
            return action(move(ee, target), 0.0, 1.0)
        if self.phase == 1:  # lower behind the cube
            target = np.array([*behind, push_z])
            if abs(ee[2] - push_z) < 0.01:
                self.phase = 2
            return action(move(ee, target), 0.0, 1.0)
        # push: advance along the line through the cube toward the goal, correcting sideways drift
        if abs(lateral) > 0.02 or along > -half + 0.005:
            self.phase = 0
            return action(move(ee, np.array([*ee[:2], h + TRAVEL])), 0.0, 1.0)
        aim = cube[:2] - direction * (half + 0.01) + direction * min(dist, 0.02)
        target = np.array([*aim, push_z])
        return action(move(ee, target, 0.012), 0.0, 1.0)


class ScriptedPickPlace(_Expert):
    """Above the object (yaw aligned) -> down -> close -> lift -> over the support -> down -> open -> rise.

    The object is the role `object`, the support the role `support` (else `goal`): the pick-place pad, the
    lower cube of a stack, the plate of a place-on. `place = False` (ScriptedPick) stops after the lift."""

    place = True

    def step(self, observation: Observation, instruction: str) -> Action:
        t = Truth.of(observation)
        m, name = self.mover, t.role("object")
        obj, rest = t.pos(name), t.rest_z(name)
        yaw_err = t.yaw_error(name, QUARTER)
        carry_z = t.table + CARRY
        dropped = obj[2] < rest + 0.02
        if self.place:
            support = self._support(t)
            top = float(t.info(support)["top_z"])
            carry_z = max(carry_z, top + 2 * float(t.info(name)["bottom"]) + 0.04)
        if self.phase == 0:  # above the object, open, aligned
            act, done = m.approach(t, obj[:2], t.table + TRAVEL, yaw_err)
        elif self.phase == 1:  # descend around it
            act, done = m.descend(t, obj[:2], rest, yaw_err)
        elif self.phase == 2:  # close
            act, done = m.grasp(self.counter)
            self.counter += 1
        elif self.phase == 3:  # lift; the object must come along
            if t.ee[2] > t.table + 0.08 and dropped:
                self._goto(0)  # dropped it: start over
                return action(np.zeros(3), 0.0, 0.0)
            act, done = m.lift(t, carry_z)
            done = done and self.place
        elif self.phase == 4:  # carry over the support
            if dropped:
                self._goto(0)
                return action(np.zeros(3), 0.0, 0.0)
            act, done = m.carry(t, name, t.pos(support)[:2], carry_z)
        elif self.phase == 5:  # lower onto the support (origin at support top + its bottom, a little drop)
            place_z = top + float(t.info(name)["bottom"]) + 0.012 + (t.ee[2] - obj[2])
            act, done = m.place(t, name, t.pos(support)[:2], place_z)
        else:  # release and rise
            self.counter += 1
            return m.release(t, self.counter)
        if done:
            self._goto(self.phase + 1)
        return act

    @staticmethod
    def _support(t: Truth) -> str:
        roles = t.privileged.get("roles") or {}
        return t.role("support") if "support" in roles else t.role("goal")


class ScriptedPick(ScriptedPickPlace):
    """Pick the role `object` (e.g. the named target among clutter) and lift it to the carry height."""

    place = False


class ScriptedOpenDrawer(_Expert):
    """Above the handle of the role `drawer` (fingers across the handle) -> down around the bar -> close -> pull
    along the drawer's opening direction; if the hand slips off the handle: open, rise and start over."""

    def step(self, observation: Observation, instruction: str) -> Action:
        t = Truth.of(observation)
        m, info = self.mover, t.info(t.role("drawer"))
        handle = np.asarray(info["handle_pos"], dtype=np.float64)
        above = max(handle[2] + 0.08, t.table + TRAVEL)
        # fingers close across the bar, parallel to the panel: the hand's x axis (yaw) along the cabinet's y axis
        yaw_err = wrap(yaw_of(np.asarray(info["quat"])) + np.pi / 2 - yaw_of(t.ee_quat), HALF)
        if self.phase == 0:  # above the handle, open, aligned with the cabinet
            act, done = m.approach(t, handle[:2], above, yaw_err, tol=0.006)
        elif self.phase == 1:  # down around the bar
            act, done = m.descend(t, handle[:2], float(handle[2]) + 0.01, yaw_err)
        elif self.phase == 2:  # close on it
            act, done = m.grasp(self.counter)
            self.counter += 1
        elif self.phase == 3:  # pull it out
            if np.linalg.norm(t.ee[:2] - handle[:2]) > 0.03:
                self._goto(4)  # slipped off
                return action(np.zeros(3), 0.0, 0.0)
            return m.pull(t, np.asarray(info["open_dir"], dtype=np.float64), float(handle[2]) + 0.01)
        else:  # open and rise before another try
            done = t.ee[2] > above - 0.02
            act = action(m.delta(t.ee, np.array([*t.ee[:2], above])), 0.0, 0.0)
            if done:
                self._goto(0)
            return act
        if done:
            self._goto(self.phase + 1)
        return act
