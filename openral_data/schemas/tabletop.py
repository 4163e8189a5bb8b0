"""What a native MuJoCo tabletop scene holds, declared in its YAML (`scene.params`): objects, a workspace, clutter,
the success criterion and the roles scripted experts read.

Objects (`objects:`, a list; `kind` picks the shape and what `size` means, all lengths in metres):
* `box`: size [x, y, z], full extents;
* `sphere`: size [radius];
* `cylinder`: size [radius, height], upright;
* `mesh`: `mesh:` a short name (MESHES: robosuite's can, milk, bread, cereal, lemon, bottle) or
  `pkg://<package>/<path>` (a file inside that installed package), `scale` multiplies it;
* `drawer`: size [width (y), depth (x), height (z)] of a fixed cabinet whose drawer slides out toward the
  cabinet's local -x (toward the robot at yaw 0) by up to `max_opening`, with a handle bar to pull.

Every object has `name` (unique, `[A-Za-z][A-Za-z0-9_]*`), `rgba`, `mass` (kg, movable objects), `friction`,
`pose` (where a seed puts it) and two flags: `movable: false` makes it a fixture (placed per episode, never
pushed around), `visual: true` a marker nothing collides with (implies a fixture). Drawers are fixtures.

`pose`: `x`, `y`, `yaw` (radians) are each a number (fixed) or `[low, high]` (uniform per seed); with
`near: {object, distance: [low, high]}` the object is placed at a random bearing and distance from an object
declared before it, and `x`/`y` bound where it may land. An object rests on the table (its lowest point on the
table top). Collidable objects never overlap at reset (footprint circles, `clutter.gap` apart): placement is
rejection sampling with at most `MAX_TRIES` tries per object, and a table layout that cannot be placed is a
ConfigError.

`clutter: {n_objects, seed, kinds, size, region, gap}` adds `n_objects` movable objects named `clutter_0`, ...:
`seed` fixes which (kind, size, colour: the model), the episode seed where (their placement). `kinds` may name
meshes (MESHES short names), which keep their own size.

`success:` one criterion (`kind` picks it) from this vocabulary, nested with `all` / `any`:
* `in_region` {object, region, resting: true, tolerance}: the object's centre (x, y) is inside `region` (an
  object's footprint: a disc for a cylinder or sphere, else its box; or an {x, y} world box) and, if `resting`,
  it rests on the table;
* `on_top` {object, support, tolerance}: the object's centre is over the support's top face, and the object
  rests on it (`on` itself would be YAML's `true`);
* `lifted` {object, height}: the object's centre is at least `height` above where it rests on the table;
* `drawer_opened` {object (a drawer), distance}: the drawer is pulled out at least `distance`;
* `all` / `any` {of: [criteria]}: every / some criterion holds.

`roles:` names objects for scripted experts (`object`, `goal`, `support`, `drawer`, ...); roles not given are
taken from the success criterion (`object` from its first leaf, `goal`/`support` from `in_region`'s region
object or `on_top`'s support, `drawer` from `drawer_opened`).
"""

from __future__ import annotations

import re
from typing import Annotated, Literal

from pydantic import Field, model_validator

from openral_data.errors import ConfigError
from openral_data.schemas.base import StrictModel

Range = tuple[float, float]
RGBA = tuple[float, float, float, float]
NAME = r"^[A-Za-z][A-Za-z0-9_]*$"
RESERVED = ("floor", "table", "sun", "robot")  # names the composed world uses itself
CLUTTER_PREFIX = "clutter_"
MAX_TRIES = 200  # placement tries per object before a table layout is refused
MAX_OBJECTS = 64
DEFAULT_TOLERANCE = 0.01
EPS = 1e-9  # slack of the containment checks (a table edge computed as 0.45 - 0.6 is -0.1499999...)
CLUTTER_KINDS = ("box", "sphere", "cylinder")

# short mesh names: the object meshes robosuite 1.5's wheel carries (metres, upright)
MESHES = {
    name: f"pkg://robosuite/models/assets/objects/meshes/{name}.stl"
    for name in ("can", "milk", "bread", "cereal", "lemon", "bottle")
}


def _ordered(value: float | Range, field: str) -> None:
    if isinstance(value, tuple) and value[0] > value[1]:
        raise ValueError(f"{field}: a range must be [low, high], got {list(value)}")


class Near(StrictModel):
    """Place relative to an object declared earlier: a random bearing, a distance in `distance`."""

    object: str
    distance: Range

    @model_validator(mode="after")
    def _check(self) -> Near:
        _ordered(self.distance, "distance")
        if self.distance[0] < 0:
            raise ValueError("distance: must be >= 0")
        return self


class Pose(StrictModel):
    x: float | Range
    y: float | Range
    yaw: float | Range = 0.0
    near: Near | None = None

    @model_validator(mode="after")
    def _check(self) -> Pose:
        for key in ("x", "y", "yaw"):
            _ordered(getattr(self, key), key)
        return self


def bounds(value: float | Range) -> Range:
    return value if isinstance(value, tuple) else (value, value)


class _Object(StrictModel):
    name: str = Field(pattern=NAME, max_length=64)
    pose: Pose
    rgba: RGBA = (0.85, 0.12, 0.1, 1.0)
    mass: float = Field(default=0.1, gt=0, le=50)
    friction: tuple[float, float, float] | None = Field(
        default=None, description="slide, torsion, roll; default 1, 0.01, 0.0001 (movable) or 1, 0.005, 0.0001"
    )
    movable: bool = True
    visual: bool = False

    @model_validator(mode="after")
    def _flags(self) -> _Object:
        if any(not 0 <= c <= 1 for c in self.rgba):
            raise ValueError("rgba: each component must be in [0, 1]")
        if self.visual and self.movable and "movable" in self.model_fields_set:
            raise ValueError("visual: a visual-only marker cannot be movable")
        if self.friction is not None and any(f < 0 for f in self.friction):
            raise ValueError("friction: must be >= 0")
        return self

    @property
    def is_movable(self) -> bool:
        return self.movable and not self.visual


class BoxObject(_Object):
    kind: Literal["box"]
    size: tuple[float, float, float] = Field(description="full extents x, y, z")

    @model_validator(mode="after")
    def _size(self) -> BoxObject:
        _positive(self.size)
        return self


class SphereObject(_Object):
    kind: Literal["sphere"]
    size: tuple[float] = Field(description="[radius]")

    @model_validator(mode="after")
    def _size(self) -> SphereObject:
        _positive(self.size)
        return self


class CylinderObject(_Object):
    kind: Literal["cylinder"]
    size: tuple[float, float] = Field(description="[radius, height]")

    @model_validator(mode="after")
    def _size(self) -> CylinderObject:
        _positive(self.size)
        return self


class MeshObject(_Object):
    kind: Literal["mesh"]
    mesh: str = Field(min_length=1, description="a MESHES short name or pkg://<package>/<path>")
    scale: float = Field(default=1.0, gt=0, le=10)

    @model_validator(mode="after")
    def _mesh(self) -> MeshObject:
        if self.mesh not in MESHES and not self.mesh.startswith("pkg://"):
            raise ValueError(f"mesh: {self.mesh!r} is neither one of {sorted(MESHES)} nor a pkg:// path")
        return self


class DrawerObject(_Object):
    kind: Literal["drawer"]
    size: tuple[float, float, float] = Field(
        default=(0.3, 0.25, 0.12), description="cabinet width (y), depth (x), height (z)"
    )
    max_opening: float | None = Field(default=None, gt=0, description="slide range; default 0.8 x depth")
    rgba: RGBA = (0.55, 0.4, 0.28, 1.0)
    mass: float = Field(default=0.5, gt=0, le=50, description="the sliding drawer's mass")
    movable: bool = False

    @model_validator(mode="after")
    def _drawer(self) -> DrawerObject:
        _positive(self.size)
        w, d, h = self.size
        if not (0.1 <= w <= 1.0 and 0.1 <= d <= 1.0 and 0.06 <= h <= 0.6):
            raise ValueError("size: a drawer cabinet is 0.1-1 m wide and deep and 0.06-0.6 m high")
        if self.movable:
            raise ValueError("movable: a drawer's cabinet is a fixture")
        if self.max_opening is not None and self.max_opening > d:
            raise ValueError(f"max_opening: at most the cabinet depth {d}")
        return self

    @property
    def opening_limit(self) -> float:
        return self.max_opening if self.max_opening is not None else 0.8 * self.size[1]


def _positive(size: tuple[float, ...]) -> None:
    if any(not 0.0005 <= s <= 2.0 for s in size):
        raise ValueError(f"size: every entry must be within 0.0005..2 m, got {list(size)}")


TabletopObject = Annotated[
    BoxObject | SphereObject | CylinderObject | MeshObject | DrawerObject, Field(discriminator="kind")
]


class Workspace(StrictModel):
    """Where the task happens: x/y on the table (world frame), z as heights above the table top."""

    x: Range
    y: Range
    z: Range = (0.0, 0.5)

    @model_validator(mode="after")
    def _check(self) -> Workspace:
        for key in ("x", "y", "z"):
            _ordered(getattr(self, key), key)
        return self


class XYRegion(StrictModel):
    x: Range
    y: Range

    @model_validator(mode="after")
    def _check(self) -> XYRegion:
        _ordered(self.x, "x")
        _ordered(self.y, "y")
        return self


class Clutter(StrictModel):
    n_objects: int = Field(ge=1, le=MAX_OBJECTS)
    seed: int = Field(default=0, ge=0, le=2**32 - 1)
    kinds: tuple[str, ...] = Field(
        default=("box", "cylinder", "sphere"),
        min_length=1,
        description="box, sphere, cylinder and MESHES short names (a mesh keeps its own size)",
    )
    size: Range = Field(default=(0.03, 0.05), description="characteristic size: box side, 2 x radius, ...")
    region: XYRegion | None = Field(default=None, description="where they go; default the workspace")
    gap: float = Field(default=0.01, ge=0, le=0.2, description="minimum gap between footprints at reset")
    mass: float = Field(default=0.1, gt=0, le=50)

    @model_validator(mode="after")
    def _check(self) -> Clutter:
        unknown = [k for k in self.kinds if k not in CLUTTER_KINDS and k not in MESHES]
        if unknown:
            raise ValueError(f"kinds: {unknown} are not among {[*CLUTTER_KINDS, *sorted(MESHES)]}")
        _ordered(self.size, "size")
        if not 0.01 <= self.size[0] <= self.size[1] <= 0.3:
            raise ValueError("size: within 0.01..0.3 m")
        return self


class InRegion(StrictModel):
    kind: Literal["in_region"]
    object: str
    region: str | XYRegion
    resting: bool = True
    tolerance: float = Field(default=DEFAULT_TOLERANCE, gt=0)


class On(StrictModel):
    kind: Literal["on_top"]
    object: str
    support: str
    tolerance: float = Field(default=DEFAULT_TOLERANCE, gt=0)


class Lifted(StrictModel):
    kind: Literal["lifted"]
    object: str
    height: float = Field(gt=0)


class DrawerOpened(StrictModel):
    kind: Literal["drawer_opened"]
    object: str
    distance: float = Field(gt=0)


class AllOf(StrictModel):
    kind: Literal["all"]
    of: list[Criterion] = Field(min_length=1)


class AnyOf(StrictModel):
    kind: Literal["any"]
    of: list[Criterion] = Field(min_length=1)


Criterion = Annotated[InRegion | On | Lifted | DrawerOpened | AllOf | AnyOf, Field(discriminator="kind")]
Leaf = InRegion | On | Lifted | DrawerOpened
AllOf.model_rebuild()
AnyOf.model_rebuild()


class TableLayout(StrictModel):
    """The objects part of `scene.params` (see the module docstring); the table comes from the scene params."""

    objects: list[TabletopObject] = Field(default_factory=list, max_length=MAX_OBJECTS)
    workspace: Workspace | None = Field(default=None, description="default: the whole table top")
    clutter: Clutter | None = None
    success: Criterion | None = None
    roles: dict[str, str] = Field(default_factory=dict)


def leaves(criterion: Criterion) -> list[tuple[str, Leaf]]:
    """Every leaf criterion with its location (`success`, `success.of[1]`, ...), depth first."""
    out: list[tuple[str, Leaf]] = []

    def walk(c: Criterion, loc: str) -> None:
        if isinstance(c, AllOf | AnyOf):
            for k, child in enumerate(c.of):
                walk(child, f"{loc}.of[{k}]")
        else:
            out.append((loc, c))

    walk(criterion, "success")
    return out


def derived_roles(layout: TableLayout) -> dict[str, str]:
    """`roles` as declared, completed from the success criterion's leaves (first one wins)."""
    roles: dict[str, str] = {}
    for _, leaf in leaves(layout.success) if layout.success is not None else []:
        if isinstance(leaf, DrawerOpened):
            roles.setdefault("drawer", leaf.object)
            continue
        roles.setdefault("object", leaf.object)
        if isinstance(leaf, On):
            roles.setdefault("support", leaf.support)
            roles.setdefault("goal", leaf.support)
        elif isinstance(leaf, InRegion) and isinstance(leaf.region, str):
            roles.setdefault("goal", leaf.region)
    return {**roles, **layout.roles}


def clutter_names(layout: TableLayout) -> list[str]:
    return [f"{CLUTTER_PREFIX}{k}" for k in range(layout.clutter.n_objects)] if layout.clutter else []


def _r(lo: float, hi: float) -> str:
    return f"[{round(lo, 6):g}, {round(hi, 6):g}]"


def check_layout(layout: TableLayout, table: XYRegion, source: str) -> None:
    """Cross-checks pydantic cannot see field by field; ConfigError `<source>.<field>: <what>` on the first."""
    declared = [o.name for o in layout.objects]
    kinds = {o.name: o.kind for o in layout.objects}
    for k, obj in enumerate(layout.objects):
        where = f"{source}.objects[{k}]"
        if obj.name in RESERVED or obj.name.startswith(CLUTTER_PREFIX):
            raise ConfigError(f"{where}.name: {obj.name!r} is reserved (also: names starting {CLUTTER_PREFIX!r})")
        if obj.name in declared[:k]:
            raise ConfigError(f"{where}.name: {obj.name!r} is declared twice")
        near = obj.pose.near
        if near is not None and near.object not in declared[:k]:
            raise ConfigError(
                f"{where}.pose.near.object: {near.object!r} is not an object declared before {obj.name!r}"
            )
    all_names = declared + clutter_names(layout)
    ws = layout.workspace
    if ws is not None:
        for axis in ("x", "y"):
            lo, hi = getattr(ws, axis)
            tlo, thi = getattr(table, axis)
            if lo < tlo - EPS or hi > thi + EPS:
                raise ConfigError(f"{source}.workspace.{axis}: {_r(lo, hi)} leaves the table top {_r(tlo, thi)}")
    area = ws if ws is not None else table
    for k, obj in enumerate(layout.objects):
        for axis in ("x", "y"):
            lo, hi = bounds(getattr(obj.pose, axis))
            alo, ahi = getattr(area, axis)
            if lo < alo - EPS or hi > ahi + EPS:
                what = "workspace" if ws is not None else "table top"
                raise ConfigError(
                    f"{source}.objects[{k}].pose.{axis}: {_r(lo, hi)} is not inside the {what} {_r(alo, ahi)}"
                )
    if layout.clutter is not None and layout.clutter.region is not None:
        for axis in ("x", "y"):
            lo, hi = getattr(layout.clutter.region, axis)
            alo, ahi = getattr(area, axis)
            if lo < alo - EPS or hi > ahi + EPS:
                raise ConfigError(f"{source}.clutter.region.{axis}: {_r(lo, hi)} is not inside {_r(alo, ahi)}")

    def known(name: str, where: str) -> None:
        if name not in all_names:
            raise ConfigError(f"{where}: no object {name!r} (declared: {', '.join(all_names) or 'none'})")

    for loc, leaf in leaves(layout.success) if layout.success is not None else []:
        where = f"{source}.{loc}"
        known(leaf.object, f"{where}.object")
        if isinstance(leaf, DrawerOpened) and kinds.get(leaf.object) != "drawer":
            raise ConfigError(f"{where}.object: {leaf.object!r} is not a drawer")
        if isinstance(leaf, On):
            known(leaf.support, f"{where}.support")
            if leaf.support == leaf.object:
                raise ConfigError(f"{where}.support: an object cannot be on itself")
        if isinstance(leaf, InRegion) and isinstance(leaf.region, str):
            known(leaf.region, f"{where}.region")
    for role, name in layout.roles.items():
        if not re.fullmatch(NAME, role):
            raise ConfigError(f"{source}.roles: {role!r} is not a role name")
        known(name, f"{source}.roles.{role}")
