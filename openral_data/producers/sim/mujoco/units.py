"""The manifest's joint units <-> the MJCF's, as the manifest's `sim.units` declares them (no per-robot code).

Arm joints: `degrees` or `radians` (same zero as the MJCF). Gripper: the manifest value `gripper_open` ..
`gripper_closed` maps linearly onto the normalised 0 (open) .. 1 (closed) the gripper wiring drives.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from openral_data.schemas.mujoco import ManifestUnits

F64 = npt.NDArray[np.float64]


class UnitMap:
    def __init__(self, units: ManifestUnits) -> None:
        self.scale = np.pi / 180.0 if units.joints == "degrees" else 1.0  # MJCF radians per manifest unit
        self.open = units.gripper_open
        self.span = units.gripper_closed - units.gripper_open

    def arm_to_sim(self, q: npt.ArrayLike) -> F64:
        return np.asarray(q, dtype=np.float64) * self.scale

    def arm_from_sim(self, q: npt.ArrayLike) -> F64:
        return np.asarray(q, dtype=np.float64) / self.scale

    def gripper_to_sim(self, value: float) -> float:
        """Manifest gripper value -> normalised closure (0 open .. 1 closed; the wiring clips)."""
        return (float(value) - self.open) / self.span

    def gripper_from_sim(self, closure: float) -> float:
        return self.open + float(closure) * self.span
