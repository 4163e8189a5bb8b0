"""Motion primitives of the scripted tabletop experts (policies/scripted.py), in one place.

Each primitive reads the scene's ground truth (`Observation.privileged` of a MuJoCo tabletop scene) and returns
a `delta_eef_gripper` action [dx, dy, dz, drx, dry, drz, gripper] (world frame, gripper 0 open .. 1 closed)
plus whether its goal is reached; the experts chain them into phases:
approach (above a point, open, yaw aligned) -> descend -> grasp (close for a few steps) -> lift -> carry (the
held object over a point) -> place (lower it) -> release (open and rise), and pull (drag a grasped handle).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from openral_data.errors import ConfigError
from openral_data.producers.sim.mujoco.placement import yaw_of
from openral_data.types import Observation, Privileged

F64 = npt.NDArray[np.float64]
Action = npt.NDArray[np.float32]
TRAVEL = 0.1  # travel height of the grasp site above the table
CARRY = 0.15  # carry height of the grasp site above the table
GRASP_STEPS = 8  # control steps the gripper is given to close
OPEN, CLOSED = 0.0, 1.0


def wrap(angle: float, period: float) -> float:
    """An angle modulo `period`, in [-period/2, period/2): a cube looks the same every quarter turn (pi/2), a
    two-finger grasp every half turn (pi)."""
    return float((angle + period / 2) % period - period / 2)


def action(dpos: F64, dyaw: float, gripper: float) -> Action:
    return np.array([*dpos, 0.0, 0.0, dyaw, gripper], dtype=np.float32)


@dataclass(frozen=True)
class Truth:
    """The ground truth an expert reads at one step."""

    privileged: Privileged
    ee: F64
    ee_quat: F64
    table: float

    @classmethod
    def of(cls, observation: Observation) -> Truth:
        p = observation.privileged
        if "ee_pos" not in p or "table_height" not in p:
            raise ConfigError("scripted experts need a MuJoCo tabletop scene (no ground truth in the observation)")
        return cls(p, np.asarray(p["ee_pos"], dtype=np.float64), np.asarray(p["ee_quat"]), float(p["table_height"]))

    def role(self, role: str) -> str:
        """The object playing `role` (privileged["roles"], from the YAML's success criterion or `roles:`)."""
        roles: dict[str, str] = self.privileged.get("roles") or {}
        if role not in roles:
            raise ConfigError(f"scene: roles: this expert needs an object in the role {role!r}; roles: {roles}")
        return roles[role]

    def info(self, name: str) -> dict[str, Any]:
        info: dict[str, Any] = self.privileged["objects"][name]
        return info

    def pos(self, name: str) -> F64:
        return np.asarray(self.info(name)["pos"], dtype=np.float64)

    def rest_z(self, name: str) -> float:
        """Height of the object's origin when it rests on the table."""
        return self.table + float(self.info(name)["bottom"])

    def yaw_error(self, name: str, period: float) -> float:
        """How far the hand must turn about the vertical to line its fingers up with the object (0 for round)."""
        info = self.info(name)
        if info["kind"] in ("sphere", "cylinder"):
            return 0.0
        return wrap(yaw_of(np.asarray(info["quat"])) - yaw_of(self.ee_quat), period)


@dataclass
class Mover:
    """Bounded proportional moves of the grasp site: at most `max_step` metres per control step."""

    max_step: float = 0.02
    gain: float = 1.0

    def delta(self, ee: F64, target: F64, max_step: float | None = None) -> F64:
        step = self.max_step if max_step is None else max_step
        d = self.gain * (target - ee)
        norm = float(np.linalg.norm(d))
        return d if norm <= step else d * (step / norm)

    # -- the primitives: (action, goal reached) --------------------------------------------------------------
    def approach(self, t: Truth, xy: F64, z: float, yaw_err: float = 0.0, tol: float = 0.008) -> tuple[Action, bool]:
        """Above `xy` at height `z`, gripper open, turning by `yaw_err`."""
        target = np.array([*xy, z])
        done = bool(np.linalg.norm(t.ee[:2] - xy) < tol and abs(yaw_err) < 0.04 and abs(t.ee[2] - z) < 0.03)
        return action(self.delta(t.ee, target), _turn(yaw_err), OPEN), done

    def descend(self, t: Truth, xy: F64, z: float, yaw_err: float = 0.0) -> tuple[Action, bool]:
        """Straight down to `z` over `xy`, gripper open."""
        target = np.array([*xy, z])
        return action(self.delta(t.ee, target), _turn(yaw_err), OPEN), abs(t.ee[2] - z) < 0.006

    @staticmethod
    def grasp(steps_so_far: int) -> tuple[Action, bool]:
        """Close in place for GRASP_STEPS steps."""
        return action(np.zeros(3), 0.0, CLOSED), steps_so_far + 1 >= GRASP_STEPS

    def lift(self, t: Truth, z: float) -> tuple[Action, bool]:
        """Straight up to `z`, gripper closed."""
        target = np.array([*t.ee[:2], z])
        return action(self.delta(t.ee, target), 0.0, CLOSED), t.ee[2] > z - 0.02

    def carry(self, t: Truth, held: str, xy: F64, z: float, tol: float = 0.01) -> tuple[Action, bool]:
        """Move so that the held object (not the hand) is centred over `xy`, at hand height `z`."""
        offset = t.ee[:2] - t.pos(held)[:2]
        target = np.array([*(xy + offset), z])
        done = bool(np.linalg.norm(t.pos(held)[:2] - xy) < tol)
        return action(self.delta(t.ee, target), 0.0, CLOSED), done

    def place(self, t: Truth, held: str, xy: F64, z: float) -> tuple[Action, bool]:
        """Lower the hand to `z` keeping the held object centred over `xy`, slowly."""
        offset = t.ee[:2] - t.pos(held)[:2]
        target = np.array([*(xy + offset), z])
        return action(self.delta(t.ee, target, 0.012), 0.0, CLOSED), abs(t.ee[2] - z) < 0.006

    def release(self, t: Truth, steps_so_far: int) -> Action:
        """Open; after a few steps rise to the travel height."""
        z = t.table + TRAVEL if steps_so_far > 6 else t.ee[2]
        return action(self.delta(t.ee, np.array([*t.ee[:2], z])), 0.0, OPEN)

    def pull(self, t: Truth, direction: F64, z: float, step: float = 0.01) -> Action:
        """Drag what the closed hand holds along `direction` (horizontal) at hand height `z`, `step` metres per
        control step."""
        flat = np.array([direction[0], direction[1], 0.0])
        target = t.ee + flat / max(float(np.linalg.norm(flat)), 1e-9) * step
        target[2] = z
        return action(self.delta(t.ee, target, 1.5 * step), 0.0, CLOSED)


def _turn(yaw_err: float) -> float:
    return float(np.clip(0.5 * yaw_err, -0.1, 0.1))
