"""Safety filter run before every `send_action`: joint limits, velocity limits and the workspace box.

Limits come from the robot manifest: `joints[].limits` and `joints[].velocity_limit` (matched to action
dimensions by name), and `safety.workspace` (the end effector's position, computed by forward kinematics of
the commanded joints — the HAL's MuJoCo twin provides it). `safety.mode` says what happens to an
out-of-bounds command:

* `clamp`: joint targets are clipped into their limits, the step from the current position is shortened to
  the velocity limit × period, and a command that would leave the workspace is cut back along the straight
  joint-space segment from the current position to the furthest point still inside (bisection);
* `refuse`: the command is not sent at all (the robot holds its last target).

Every intervention is returned as an `Intervention` so the loop writes it into the episode record.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from openral_data.errors import ConfigError
from openral_data.schemas.hal import SafetyMode
from openral_data.schemas.robot import RobotManifest

F32 = npt.NDArray[np.float32]
F64 = npt.NDArray[np.float64]
ForwardKinematics = Callable[[F64], F64]  # action-space joint targets -> end-effector xyz (base frame)
Kind = Literal["joint_limit", "velocity_limit", "workspace"]


@dataclass(frozen=True)
class Intervention:
    kind: Kind
    name: str  # the action dimension, or "end_effector"
    commanded: float | list[float]
    applied: float | list[float] | None  # None: refused

    def to_json(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True)
class SafetyResult:
    applied: F32 | None  # None: refused (nothing is sent)
    interventions: list[Intervention]

    @property
    def refused(self) -> bool:
        return self.applied is None


class SafetyFilter:
    """Per-dimension bounds of the manifest's action vector, plus the optional workspace check."""

    def __init__(
        self,
        robot: RobotManifest,
        *,
        mode: SafetyMode | None = None,
        fk: ForwardKinematics | None = None,
        names: list[str] | None = None,
        state_names: list[str] | None = None,
        source: str = "robot.yaml",
    ) -> None:
        """`names` / `state_names` default to the manifest's action and state names."""
        self.robot = robot
        self.mode: SafetyMode = mode or robot.safety.mode
        if names is None:
            names = robot.action.names or [j.name for j in robot.joints][: robot.action.dim]
            if len(names) != robot.action.dim:
                raise ConfigError(f"{source}: action.names: needed to match action dimensions to joints")
        self.names = list(names)
        joints = {j.name: j for j in robot.joints}
        n = len(names)
        self.lower = np.full(n, -np.inf)
        self.upper = np.full(n, np.inf)
        self.velocity = np.full(n, np.inf)
        for i, name in enumerate(names):
            joint = joints.get(name)
            if joint is None:
                continue
            if joint.limits is not None:
                self.lower[i], self.upper[i] = joint.limits
            if joint.velocity_limit is not None:
                self.velocity[i] = joint.velocity_limit
        if state_names is None:
            state_names = robot.observation.state.names or []
        self._state_index = [state_names.index(n) if n in state_names else -1 for n in names]
        self.workspace = robot.safety.workspace
        if self.workspace is not None and fk is None:
            raise ConfigError(
                f"{source}: safety.workspace: needs forward kinematics, which this HAL does not have "
                "(the workspace is checked on the MuJoCo twin; remove it or give the robot a sim: block)"
            )
        self.fk = fk

    def current(self, state: F32) -> F64:
        """The action-space view of a state vector (dimensions without a matching state entry: NaN)."""
        out = np.full(len(self.names), np.nan)
        for i, k in enumerate(self._state_index):
            if k >= 0:
                out[i] = float(state[k])
        return out

    def _inside(self, q: F64) -> bool:
        assert self.fk is not None and self.workspace is not None
        p = self.fk(q)
        w = self.workspace
        return bool(w.x[0] <= p[0] <= w.x[1] and w.y[0] <= p[1] <= w.y[1] and w.z[0] <= p[2] <= w.z[1])

    def apply(self, action: F32, state: F32, dt: float) -> SafetyResult:
        """Bound `action` given the current `state` and the control period `dt` (seconds)."""
        cmd = action.astype(np.float64)
        q = cmd.copy()
        found: list[Intervention] = []
        cur = self.current(state)

        clipped = np.clip(q, self.lower, self.upper)
        for i in np.flatnonzero(clipped != q):
            found.append(Intervention("joint_limit", self.names[i], float(q[i]), float(clipped[i])))
        q = clipped

        step = np.where(np.isnan(cur), 0.0, q - cur)
        max_step = self.velocity * dt
        limited = np.where(np.isnan(cur), q, cur + np.clip(step, -max_step, max_step))
        for i in np.flatnonzero(np.abs(step) > max_step):
            found.append(Intervention("velocity_limit", self.names[i], float(q[i]), float(limited[i])))
        q = limited

        if self.fk is not None and self.workspace is not None and not self._inside(q):
            fk = self.fk
            start = np.where(np.isnan(cur), q, cur)
            lo, hi = 0.0, 1.0
            if not self._inside(start):
                hi = 0.0  # already outside: do not move further
            else:
                for _ in range(20):
                    mid = (lo + hi) / 2
                    if self._inside(start + mid * (q - start)):
                        lo = mid
                    else:
                        hi = mid
            inside = start + lo * (q - start)
            found.append(
                Intervention("workspace", "end_effector", [float(v) for v in fk(q)], [float(v) for v in fk(inside)])
            )
            q = inside

        if found and self.mode == "refuse":
            refused = [Intervention(i.kind, i.name, i.commanded, None) for i in found]
            return SafetyResult(None, refused)
        return SafetyResult(q.astype(np.float32), found)
