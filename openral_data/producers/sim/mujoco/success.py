"""The declarative success criteria of a tabletop scene (schemas/tabletop.py), evaluated on the simulator state.

Geometry (objects upright; `bottom` = the body origin's height above the object's lowest point):
* resting on the table: |z - (table + bottom)| <= tolerance;
* inside a region object: the point in the region object's frame is within its footprint (a disc of its
  radius for a cylinder or sphere, else its bounding box in x/y);
* on a support: the object's centre is inside the support's footprint and |z - (support top + bottom)| <=
  tolerance, support top = the support's z + its bounding box's top;
* lifted: z - (table + bottom) >= height;
* drawer opened: the slide joint's position (metres pulled out) >= distance.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
import numpy.typing as npt

from openral_data.producers.sim.mujoco.placement import Extent, yaw_of
from openral_data.schemas.tabletop import AllOf, AnyOf, Criterion, DrawerOpened, InRegion, Lifted, On

F64 = npt.NDArray[np.float64]


class WorldView(Protocol):
    """What the criteria read: poses, extents, drawer openings and the table height."""

    @property
    def table_height(self) -> float: ...

    def pos(self, name: str) -> F64: ...

    def quat(self, name: str) -> F64: ...

    def extent(self, name: str) -> Extent: ...

    def opening(self, name: str) -> float: ...


def _local_xy(view: WorldView, frame: str, point: F64) -> F64:
    """`point` (x, y) in the frame of object `frame` (its yaw about the vertical)."""
    yaw = yaw_of(view.quat(frame))
    d = point[:2] - view.pos(frame)[:2]
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])


def _inside(view: WorldView, frame: str, point: F64) -> bool:
    e = view.extent(frame)
    local = _local_xy(view, frame, point)
    if e.round:
        return bool(np.linalg.norm(local) <= e.hi[0])
    return bool(e.lo[0] <= local[0] <= e.hi[0] and e.lo[1] <= local[1] <= e.hi[1])


def _rest_height(view: WorldView, name: str) -> float:
    """How far the object's centre is above where it would rest on the table."""
    return float(view.pos(name)[2] - (view.table_height + view.extent(name).bottom))


def holds(criterion: Criterion, view: WorldView) -> bool:
    if isinstance(criterion, AllOf):
        return all(holds(c, view) for c in criterion.of)
    if isinstance(criterion, AnyOf):
        return any(holds(c, view) for c in criterion.of)
    if isinstance(criterion, DrawerOpened):
        return view.opening(criterion.object) >= criterion.distance
    if isinstance(criterion, Lifted):
        return _rest_height(view, criterion.object) >= criterion.height
    centre = view.pos(criterion.object)
    if isinstance(criterion, InRegion):
        region = criterion.region
        if isinstance(region, str):
            inside = _inside(view, region, centre)
        else:
            inside = bool(region.x[0] <= centre[0] <= region.x[1] and region.y[0] <= centre[1] <= region.y[1])
        resting = not criterion.resting or abs(_rest_height(view, criterion.object)) <= criterion.tolerance
        return inside and resting
    assert isinstance(criterion, On)
    support = criterion.support
    top = float(view.pos(support)[2] + view.extent(support).hi[2])
    level = abs(float(centre[2]) - (top + view.extent(criterion.object).bottom)) <= criterion.tolerance
    return level and _inside(view, support, centre)


def _label(criterion: Criterion) -> str:
    if isinstance(criterion, DrawerOpened):
        return f"{criterion.object} open {criterion.distance:g} m"
    if isinstance(criterion, Lifted):
        return f"{criterion.object} lifted {criterion.height:g} m"
    if isinstance(criterion, InRegion):
        region = criterion.region if isinstance(criterion.region, str) else "region"
        return f"{criterion.object} in {region}"
    assert isinstance(criterion, On)
    return f"{criterion.object} on {criterion.support}"


def terms(criterion: Criterion, view: WorldView) -> list[tuple[str, bool]]:
    """The criterion's leaves, each with whether it holds now (`cube in goal`, `drawer open 0.1 m`): what a
    person at the controls is told as they change (producers/hal/teleop/status.py)."""
    if isinstance(criterion, AllOf | AnyOf):
        return [term for c in criterion.of for term in terms(c, view)]
    return [(_label(criterion), holds(criterion, view))]
