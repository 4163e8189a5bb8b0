"""Tabletop tasks: how a seed places the cube and the goal, and the geometric success test.

* `push`: the goal is a flat disc (visual only) on the table; success = the cube's centre is within
  `goal_radius` of the disc's centre (x/y) while the cube rests on the table.
* `pick_place`: the goal is a raised square pad (2 cm, solid), so the cube must be lifted onto it; success =
  the cube's centre is over the pad (|dx|, |dy| <= pad half-size) and the cube rests on the pad's top.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

from openral_data.schemas.mujoco import TabletopParams

F64 = npt.NDArray[np.float64]

TaskKind = Literal["push", "pick_place"]
PAD_HEIGHT = 0.02
REST_TOLERANCE = 0.01


@dataclass(frozen=True)
class Placement:
    cube_pos: F64
    cube_yaw: float
    goal_pos: F64


def sample_placement(kind: TaskKind, params: TabletopParams, rng: np.random.Generator) -> Placement:
    """Cube and goal poses for one episode; a pure function of the generator's state."""
    h, half = params.table_height, params.cube_size / 2
    cr, gr = params.cube_region, params.goal_region
    cube_xy = np.array([rng.uniform(*cr.x), rng.uniform(*cr.y)])
    yaw = float(rng.uniform(*params.cube_yaw))
    goal_xy = None
    for _ in range(1000):
        angle = rng.uniform(-np.pi, np.pi)
        dist = rng.uniform(params.goal_min_distance, params.goal_max_distance)
        cand = cube_xy + dist * np.array([np.cos(angle), np.sin(angle)])
        if gr.x[0] <= cand[0] <= gr.x[1] and gr.y[0] <= cand[1] <= gr.y[1]:
            goal_xy = cand
            break
    if goal_xy is None:  # regions that cannot hold the distance: take the farthest corner of the goal region
        corners = np.array([[x, y] for x in gr.x for y in gr.y])
        goal_xy = corners[np.argmax(np.linalg.norm(corners - cube_xy, axis=1))]
    return Placement(
        cube_pos=np.array([cube_xy[0], cube_xy[1], h + half]),
        cube_yaw=yaw,
        goal_pos=np.array([goal_xy[0], goal_xy[1], h]),
    )


def is_success(kind: TaskKind, params: TabletopParams, cube_pos: F64, goal_pos: F64) -> bool:
    h, half = params.table_height, params.cube_size / 2
    d = cube_pos[:2] - goal_pos[:2]
    if kind == "push":
        return bool(np.linalg.norm(d) <= params.goal_radius and abs(cube_pos[2] - (h + half)) <= REST_TOLERANCE)
    on_pad = bool(np.abs(d).max() <= params.goal_radius)
    return on_pad and abs(cube_pos[2] - (h + PAD_HEIGHT + half)) <= REST_TOLERANCE
