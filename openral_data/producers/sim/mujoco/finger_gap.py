"""Gripper width in metres: the gap between the two fingers' pads (state representation `eef_pose_gripper_width`).

Each finger is the subtree of the body a gripper joint moves (`sim.gripper.joints`, the first two); its pad is
the finger's collision geom nearest the grasp site with the gripper open (found once, when the scene is built).
The width is MuJoCo's distance between the two pads (`mj_geomDistance`), 0 when they touch or press together.
A gripper with fewer than two finger joints (one jaw against a fixed one) has no width here.
"""

from __future__ import annotations

import mujoco
import numpy as np

from openral_data.errors import ConfigError

MAX_GAP = 1.0  # metres: no gripper opens wider


def _finger_geoms(model: mujoco.MjModel, root: int) -> list[int]:
    """Collision geoms of body `root` and every body below it."""
    bodies = {root}
    for b in range(root + 1, model.nbody):  # a child's id is above its parent's
        if int(model.body_parentid[b]) in bodies:
            bodies.add(b)
    return [
        g
        for g in range(model.ngeom)
        if int(model.geom_bodyid[g]) in bodies and (model.geom_contype[g] or model.geom_conaffinity[g])
    ]


class FingerGap:
    """Measures the pad gap; build it with the gripper open and kinematics current (`mj_forward`)."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, joints: list[str], site: int, source: str) -> None:
        if len(joints) < 2:
            raise ConfigError(
                f"{source}: sim.gripper.joints: a gripper width needs two finger joints, this gripper has {len(joints)}"
            )
        self._model = model
        pads: list[int] = []
        for k, joint in enumerate(joints[:2]):
            geoms = _finger_geoms(model, int(model.jnt_bodyid[model.joint(joint).id]))
            if not geoms:
                raise ConfigError(f"{source}: sim.gripper.joints[{k}]: the finger {joint!r} has no collision geom")
            site_pos = data.site_xpos[site]
            pads.append(min(geoms, key=lambda g: float(np.linalg.norm(data.geom_xpos[g] - site_pos))))
        self.pads = (pads[0], pads[1])

    def width(self, data: mujoco.MjData) -> float:
        gap = mujoco.mj_geomDistance(self._model, data, self.pads[0], self.pads[1], MAX_GAP, None)
        return float(max(gap, 0.0))
