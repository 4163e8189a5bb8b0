"""What a person at the controls is told every few ticks (the teleop status lines on the terminal).

The first line is where the gripper is: `eef 0.412 -0.031 0.911 gripper open` (the end effector's world
position when the scene reports it, else the first three state values), with the keyboard's presses not yet
paid out. The second, when the scene reports its ground truth (a MuJoCo tabletop scene's
`Observation.privileged`), is where the scene's objects are *from the gripper*, along the world axes the keys
and sticks move (`cube +0.120 -0.050 -0.230`: 12 cm ahead in x, 5 cm to the right in y, 23 cm down), one per
role of the task (the object, the goal or support), then the scene's success terms as they hold now
(`success: cube in goal no`). A person who cannot see the scene drives from these two lines alone.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from openral_data.types import Observation

F64 = npt.NDArray[np.float64]


def gripper_position(observation: Observation) -> F64:
    ee = observation.privileged.get("ee_pos")
    return np.asarray(ee if ee is not None else observation.state[:3], dtype=np.float64)


def eef_line(observation: Observation, gripper: float) -> str:
    """`eef 0.412 -0.031 0.911 gripper open`."""
    pos = gripper_position(observation)
    return f"eef {pos[0]:.3f} {pos[1]:.3f} {pos[2]:.3f} gripper {'closed' if gripper else 'open'}"


def scene_line(observation: Observation) -> str | None:
    """`cube +0.120 -0.050 -0.230 · goal +0.300 +0.100 -0.250 · success: cube in goal no` (offsets from the
    gripper, metres, world x y z); None when the scene reports no objects (a real robot, a suite scene)."""
    p = observation.privileged
    objects: dict[str, Any] = p.get("objects") or {}
    roles: dict[str, str] = p.get("roles") or {}
    if not objects or not roles:
        return None
    here = gripper_position(observation)
    parts = []
    for name in dict.fromkeys(roles.values()):  # each object once, in the roles' order
        if name in objects:
            d = np.asarray(objects[name]["pos"], dtype=np.float64) - here
            parts.append(f"{name} {d[0]:+.3f} {d[1]:+.3f} {d[2]:+.3f}")
    terms = p.get("success_terms") or []
    if terms:
        parts.append("success: " + ", ".join(f"{label} {'yes' if ok else 'no'}" for label, ok in terms))
    return " · ".join(parts) if parts else None


def status_lines(observation: Observation, first: str) -> str:
    """`first` (the device's own line), and the scene's line under it when there is one."""
    scene = scene_line(observation)
    return first if scene is None else f"{first}\r\n  {scene}"
