"""Where a tabletop scene's objects are: the clutter a seed adds, each object's extent in the compiled model,
and the seeded, non-overlapping placement of every object at reset.

Placement draws, per object in declaration order (then the clutter), from `numpy.random.default_rng(seed)`:
`x`, `y`, `yaw` for each of them given as a range (a fixed number draws nothing), or, with `near`, a bearing and
a distance from the named object, then `yaw`. A candidate is kept when it lies in its `x`/`y` bounds and its
footprint circle (around the body origin, covering the object at any yaw) stays `gap` clear of every collidable
object placed before it and of the robot's base (ROBOT_CLEARANCE around its axis); otherwise it is drawn again,
at most `MAX_TRIES` times (ConfigError after that). An object rests on the table top: its lowest point (upright)
at the table's height.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from openral_data.errors import ConfigError
from openral_data.schemas.tabletop import (
    CLUTTER_PREFIX,
    MAX_TRIES,
    MESHES,
    BoxObject,
    CylinderObject,
    MeshObject,
    Pose,
    SphereObject,
    TableLayout,
    TabletopObject,
    Workspace,
    XYRegion,
    bounds,
)

F64 = npt.NDArray[np.float64]
PALETTE = (
    (0.9, 0.6, 0.1),
    (0.2, 0.6, 0.9),
    (0.6, 0.3, 0.8),
    (0.95, 0.85, 0.2),
    (0.3, 0.8, 0.6),
    (0.9, 0.4, 0.6),
    (0.5, 0.5, 0.5),
    (0.4, 0.25, 0.1),
)
DEFAULT_GAP = 0.01
ROBOT_CLEARANCE = 0.15  # radius around the robot base's axis that no collidable object is placed in


@dataclass(frozen=True)
class Extent:
    """An object's bounding box in its body frame (closed drawer, handle included): `lo`, `hi` corners."""

    lo: F64
    hi: F64
    round: bool  # a disc footprint (sphere, cylinder): regions and supports use `hi[0]` as the radius

    @property
    def size(self) -> F64:
        return np.asarray(self.hi - self.lo, dtype=np.float64)

    @property
    def bottom(self) -> float:
        """Height of the body origin above the object's lowest point (upright)."""
        return float(-self.lo[2])

    @property
    def radius(self) -> float:
        """Footprint radius around the body origin, covering the object at any yaw."""
        corners = np.array([[x, y] for x in (self.lo[0], self.hi[0]) for y in (self.lo[1], self.hi[1])])
        return float(np.linalg.norm(corners, axis=1).max())


def expand_clutter(layout: TableLayout, area: XYRegion | Workspace) -> list[TabletopObject]:
    """The declared objects followed by the clutter `clutter.seed` picks (kinds, sizes and colours)."""
    objects: list[TabletopObject] = list(layout.objects)
    c = layout.clutter
    if c is None:
        return objects
    rng = np.random.default_rng(c.seed)
    region = c.region or area
    for k in range(c.n_objects):
        kind = c.kinds[int(rng.integers(len(c.kinds)))]
        s = float(rng.uniform(*c.size))
        colour = PALETTE[int(rng.integers(len(PALETTE)))]
        common = {
            "name": f"{CLUTTER_PREFIX}{k}",
            "mass": c.mass,
            "rgba": (*colour, 1.0),
            "pose": Pose(x=region.x, y=region.y, yaw=(-np.pi, np.pi)),
        }
        objects.append(MeshObject(kind="mesh", mesh=kind, **common) if kind in MESHES else primitive(kind, s, common))
    return objects


def primitive(kind: str, s: float, common: dict[str, Any]) -> TabletopObject:
    """A box (side `s`), sphere or cylinder (diameter and height `s`) with the other fields in `common`."""
    if kind == "box":
        return BoxObject(kind="box", size=(s, s, s), **common)
    if kind == "sphere":
        return SphereObject(kind="sphere", size=(s / 2,), **common)
    return CylinderObject(kind="cylinder", size=(s / 2, s), **common)


def _corners(half: F64) -> F64:
    return np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half


def extents(model: mujoco.MjModel, objects: Sequence[TabletopObject]) -> dict[str, Extent]:
    """Each object's body-frame bounding box from the compiled model (mesh vertices, primitive sizes)."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    out: dict[str, Extent] = {}
    for obj in objects:
        bid = model.body(obj.name).id
        bodies = {bid} | {b for b in range(model.nbody) if model.body_parentid[b] == bid and b != bid}
        origin, rot = data.xpos[bid], data.xmat[bid].reshape(3, 3)
        points = []
        for g in range(model.ngeom):
            if model.geom_bodyid[g] not in bodies:
                continue
            gtype, size = model.geom_type[g], model.geom_size[g]
            if gtype == mujoco.mjtGeom.mjGEOM_MESH:
                m = model.geom_dataid[g]
                adr, n = model.mesh_vertadr[m], model.mesh_vertnum[m]
                local = np.asarray(model.mesh_vert[adr : adr + n], dtype=np.float64)
            elif gtype == mujoco.mjtGeom.mjGEOM_SPHERE:
                local = _corners(np.full(3, size[0]))
            elif gtype in (mujoco.mjtGeom.mjGEOM_CYLINDER,):
                local = _corners(np.array([size[0], size[0], size[1]]))
            elif gtype == mujoco.mjtGeom.mjGEOM_CAPSULE:
                local = _corners(np.array([size[0], size[0], size[1] + size[0]]))
            else:
                local = _corners(np.asarray(size[:3], dtype=np.float64))
            world = data.geom_xpos[g] + local @ data.geom_xmat[g].reshape(3, 3).T
            points.append((world - origin) @ rot)
        pts = np.concatenate(points)
        out[obj.name] = Extent(pts.min(axis=0), pts.max(axis=0), round=obj.kind in ("sphere", "cylinder"))
    return out


@dataclass(frozen=True)
class Placed:
    pos: F64  # body origin, world frame
    yaw: float


def _draw(rng: np.random.Generator, value: float | tuple[float, float]) -> float:
    return float(rng.uniform(*value)) if isinstance(value, tuple) else float(value)


def place(
    objects: Sequence[TabletopObject],
    ext: dict[str, Extent],
    table_height: float,
    rng: np.random.Generator,
    gap: float,
    source: str,
    keep_clear: Sequence[tuple[F64, float]] = (),
) -> dict[str, Placed]:
    """Every object's reset pose; a pure function of the generator's state (see the module docstring).
    `keep_clear`: (x/y centre, radius) discs no collidable object may overlap (the robot's base)."""
    placed: dict[str, Placed] = {}
    solid: list[tuple[F64, float]] = list(keep_clear)  # footprints of what is already on the table
    for obj in objects:
        e, pose = ext[obj.name], obj.pose
        (xlo, xhi), (ylo, yhi) = bounds(pose.x), bounds(pose.y)
        radius = e.radius
        for _ in range(MAX_TRIES):
            if pose.near is not None:
                angle = rng.uniform(-np.pi, np.pi)
                dist = rng.uniform(*pose.near.distance)
                xy = placed[pose.near.object].pos[:2] + dist * np.array([np.cos(angle), np.sin(angle)])
                if not (xlo <= xy[0] <= xhi and ylo <= xy[1] <= yhi):
                    continue
            else:
                xy = np.array([_draw(rng, pose.x), _draw(rng, pose.y)])
            yaw = _draw(rng, pose.yaw)
            if obj.visual or all(np.linalg.norm(xy - c) >= radius + r + gap for c, r in solid):
                break
        else:
            raise ConfigError(
                f"{source}: cannot place {obj.name!r} clear of the robot base and the objects placed before it in "
                f"{MAX_TRIES} tries "
                "(widen its pose range or the clutter region, or use fewer or smaller objects)"
            )
        placed[obj.name] = Placed(np.array([xy[0], xy[1], table_height + e.bottom]), yaw)
        if not obj.visual:
            solid.append((xy, radius))
    return placed


def yaw_quat(yaw: float) -> F64:
    return np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])


def yaw_of(quat: F64) -> float:
    """Heading of the frame's x axis projected on the table (quaternion [qw, qx, qy, qz])."""
    w, x, y, z = (float(v) for v in quat)
    return float(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))
