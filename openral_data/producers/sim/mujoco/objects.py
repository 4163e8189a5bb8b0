"""MJCF of the table side of a tabletop world: floor, table, light and the scene's declared objects.

Each object is one body named after it, its origin at its geometric centre (a mesh: the mesh's own frame):
* movable: a free joint (named after the object) and its geom(s);
* a fixture (`movable: false`, `visual: true`, drawers): a mocap body, moved per episode without recompiling;
  a visual marker's geoms collide with nothing;
* a drawer: the mocap cabinet (bottom, top, side and back walls) with a child body `<name>/drawer` (box, front
  panel, an upright handle bar 5 cm in front of the panel on two posts, site `<name>/handle` at the bar's
  centre) on a slide joint named after the object, opening toward the cabinet's local -x (toward the robot at
  yaw 0), 0..`max_opening` metres.
  The cabinet's walls and the drawer never collide (an explicit exclude; the joint limits the slide).
All scene geoms are in geom group SCENE_GROUP.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import mujoco

from openral_data.errors import ConfigError
from openral_data.producers.sim.mujoco.assets import resolve_asset
from openral_data.schemas.randomize import TEXTURES
from openral_data.schemas.tabletop import MESHES, DrawerObject, MeshObject, TabletopObject

SCENE_GROUP = 2  # geom group of the table, floor and objects; robot MJCFs use 0 (collision) and 1 (visual)
MOVABLE_FRICTION = (1.0, 0.01, 0.0001)
FIXTURE_FRICTION = (1.0, 0.005, 0.0001)
WALL = 0.01  # drawer cabinet wall thickness
HANDLE_RADIUS = 0.008
HANDLE_OFFSET = 0.05  # bar axis in front of the drawer's front panel
DRAWER_DAMPING = 2.0
DRAWER_FRICTIONLOSS = 0.2
GEOM = mujoco.mjtGeom
MESH_SUFFIXES = (".stl", ".obj", ".msh")
MATERIAL_PREFIX = "rand/"  # the shipped textures' materials (add_textures)
_BUILTIN = {
    "checker": mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
    "gradient": mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
    "flat": mujoco.mjtBuiltin.mjBUILTIN_FLAT,
}
_MARK = {
    "none": mujoco.mjtMark.mjMARK_NONE,
    "edge": mujoco.mjtMark.mjMARK_EDGE,
    "random": mujoco.mjtMark.mjMARK_RANDOM,
}
Vec3 = tuple[float, float, float]


def rgba(r: float, g: float, b: float, a: float = 1.0) -> list[float]:
    return [r, g, b, a]


def add_table(
    world: mujoco.MjSpec,
    height: float,
    size: tuple[float, float],
    center: tuple[float, float],
) -> None:
    """Floor plane, the table box (top at `height`) and the directional light."""
    world.add_material(name="matte", specular=0.05, shininess=0.1)
    world.worldbody.add_geom(
        name="floor",
        type=GEOM.mjGEOM_PLANE,
        size=[3, 3, 0.1],
        rgba=rgba(0.55, 0.57, 0.6),
        material="matte",
        group=SCENE_GROUP,
    )
    world.worldbody.add_geom(
        name="table",
        type=GEOM.mjGEOM_BOX,
        size=[size[0] / 2, size[1] / 2, height / 2],
        pos=[center[0], center[1], height / 2],
        rgba=rgba(0.72, 0.64, 0.52),
        material="matte",
        group=SCENE_GROUP,
        friction=list(FIXTURE_FRICTION),
    )
    # mujoco >= 3.8 says `type=mjLIGHT_DIRECTIONAL` (its `directional` flag is gone); 3.3 only knows the flag
    light_type = getattr(mujoco, "mjtLightType", None)
    directional: dict[str, object] = (
        {"type": light_type.mjLIGHT_DIRECTIONAL} if light_type is not None else {"directional": True}
    )
    world.worldbody.add_light(
        name="sun",
        **directional,
        dir=[-0.3, 0.2, -1.0],
        diffuse=[0.5, 0.5, 0.5],
        specular=[0.05, 0.05, 0.05],
        castshadow=True,
    )


def add_textures(world: mujoco.MjSpec) -> None:
    """The shipped textures (schemas/randomize.py), each a material ``rand/<name>`` a geom can be switched to."""
    for name, (builtin, mark, rgb1, rgb2, repeat) in TEXTURES.items():
        world.add_texture(
            name=f"{MATERIAL_PREFIX}{name}",
            type=mujoco.mjtTexture.mjTEXTURE_2D,
            builtin=_BUILTIN[builtin],
            mark=_MARK[mark],
            rgb1=list(rgb1),
            rgb2=list(rgb2),
            markrgb=list(rgb2),
            random=0.15 if mark == "random" else 0.0,
            width=64,
            height=64,
        )
        world.add_material(
            name=f"{MATERIAL_PREFIX}{name}",
            textures=["", f"{MATERIAL_PREFIX}{name}"],
            texrepeat=[repeat, repeat],
            texuniform=True,
            specular=0.05,
        )


def add_objects(world: mujoco.MjSpec, objects: Sequence[TabletopObject], source: str) -> None:
    """One body per object (see the module docstring); `source` names the objects list for asset errors."""
    for k, obj in enumerate(objects):
        body = world.worldbody.add_body(name=obj.name, mocap=not obj.is_movable)
        if obj.is_movable:
            body.add_freejoint(name=obj.name)
        if isinstance(obj, DrawerObject):
            _drawer(body, obj)
            # a mocap cabinet counts as part of the world, so parent-child filtering would not apply
            world.add_exclude(bodyname1=obj.name, bodyname2=f"{obj.name}/drawer")
            continue
        friction = obj.friction or (MOVABLE_FRICTION if obj.is_movable else FIXTURE_FRICTION)
        geom: dict[str, object] = {
            "name": obj.name,
            "rgba": list(obj.rgba),
            "group": SCENE_GROUP,
            "friction": list(friction),
        }
        if obj.is_movable:
            geom.update(mass=obj.mass, condim=4)
        if obj.visual:
            geom.update(contype=0, conaffinity=0)
        if obj.kind == "box":
            body.add_geom(type=GEOM.mjGEOM_BOX, size=[s / 2 for s in obj.size], **geom)
        elif obj.kind == "sphere":
            body.add_geom(type=GEOM.mjGEOM_SPHERE, size=[obj.size[0], 0, 0], **geom)
        elif obj.kind == "cylinder":
            body.add_geom(type=GEOM.mjGEOM_CYLINDER, size=[obj.size[0], obj.size[1] / 2, 0], **geom)
        else:
            path = mesh_file(obj, f"{source}[{k}].mesh")
            world.add_mesh(name=f"{obj.name}_mesh", file=str(path), scale=[obj.scale] * 3)
            body.add_geom(type=GEOM.mjGEOM_MESH, meshname=f"{obj.name}_mesh", **geom)


def mesh_file(obj: MeshObject, source: str) -> Path:
    """The mesh file a short name or `pkg://` reference names, inside its package, that MuJoCo can load
    (ConfigError otherwise; a path leading out of the package: DatasetError `dataset.unsafe`)."""
    ref = MESHES.get(obj.mesh, obj.mesh)
    path = resolve_asset(ref, Path("."), source)
    if path.suffix.lower() not in MESH_SUFFIXES:
        raise ConfigError(f"{source}: {ref}: not a mesh file (MuJoCo loads {', '.join(MESH_SUFFIXES)})")
    probe = mujoco.MjSpec()
    probe.add_mesh(name="probe", file=str(path))
    probe.worldbody.add_geom(type=GEOM.mjGEOM_MESH, meshname="probe")
    try:
        probe.compile()
    except ValueError as exc:
        raise ConfigError(f"{source}: {ref}: MuJoCo cannot load this mesh: {' '.join(str(exc).split())}") from None
    return path


def _drawer(cabinet: mujoco.MjsBody, obj: DrawerObject) -> None:
    """A cabinet (`cabinet`: its body, origin at its centre, open toward -x) with a drawer sliding out of it: the
    carcass walls, the drawer's body and slide joint, its box, and the handle on its front panel, in that order."""
    _carcass(cabinet, obj)
    drawer = _drawer_slide(cabinet, obj)
    _drawer_box(drawer, obj)
    _handle(drawer, obj)


def _carcass(cabinet: mujoco.MjsBody, obj: DrawerObject) -> None:
    """The cabinet's five walls: origin at its centre, open toward -x."""
    w, d, h = obj.size
    t = WALL
    shell: dict[str, object] = {"rgba": list(obj.rgba), "group": SCENE_GROUP, "friction": list(FIXTURE_FRICTION)}
    walls: tuple[tuple[str, Vec3, Vec3], ...] = (
        ("bottom", (d / 2, w / 2, t / 2), (0, 0, -h / 2 + t / 2)),
        ("top", (d / 2, w / 2, t / 2), (0, 0, h / 2 - t / 2)),
        ("left", (d / 2, t / 2, h / 2), (0, w / 2 - t / 2, 0)),
        ("right", (d / 2, t / 2, h / 2), (0, -w / 2 + t / 2, 0)),
        ("back", (t / 2, w / 2, h / 2), (d / 2 - t / 2, 0, 0)),
    )
    for part, size, pos in walls:
        cabinet.add_geom(name=f"{obj.name}/{part}", type=GEOM.mjGEOM_BOX, size=list(size), pos=list(pos), **shell)


def _drawer_slide(cabinet: mujoco.MjsBody, obj: DrawerObject) -> mujoco.MjsBody:
    """The drawer's body inside the cabinet, on a damped slide joint (named as the object) opening toward -x."""
    drawer = cabinet.add_body(name=f"{obj.name}/drawer")
    drawer.add_joint(
        name=obj.name,
        type=mujoco.mjtJoint.mjJNT_SLIDE,
        axis=[-1.0, 0.0, 0.0],
        range=[0.0, obj.opening_limit],
        limited=mujoco.mjtLimited.mjLIMITED_TRUE,
        damping=DRAWER_DAMPING,
        frictionloss=DRAWER_FRICTIONLOSS,
        armature=0.01,
    )
    return drawer


def _drawer_box(drawer: mujoco.MjsBody, obj: DrawerObject) -> None:
    """The drawer: a box inside the cabinet, its front panel flush with the cabinet's front face when closed;
    80 % of the object's mass, spread by volume."""
    w, d, h = obj.size
    t = WALL
    iw, ih = w - 2 * t - 0.004, h - 2 * t - 0.004  # inner drawer width / height, 2 mm clearance
    depth = d - 2 * t
    x0 = -d / 2  # the cabinet's front face
    parts: tuple[tuple[str, Vec3, Vec3], ...] = (
        ("drawer_bottom", (depth / 2, iw / 2, t / 2), (x0 + depth / 2, 0, -ih / 2 + t / 2)),
        ("drawer_left", (depth / 2, t / 2, ih / 2), (x0 + depth / 2, iw / 2 - t / 2, 0)),
        ("drawer_right", (depth / 2, t / 2, ih / 2), (x0 + depth / 2, -iw / 2 + t / 2, 0)),
        ("drawer_back", (t / 2, iw / 2, ih / 2), (x0 + depth - t / 2, 0, 0)),
        ("front", (t / 2, w / 2, h / 2), (x0 - t / 2, 0, 0)),
    )
    volumes = [8 * s[0] * s[1] * s[2] for _, s, _ in parts]
    front = [min(1.0, c * 1.15) for c in obj.rgba[:3]] + [obj.rgba[3]]
    for (part, size, pos), vol in zip(parts, volumes, strict=True):
        drawer.add_geom(
            name=f"{obj.name}/{part}",
            type=GEOM.mjGEOM_BOX,
            size=list(size),
            pos=list(pos),
            mass=0.8 * obj.mass * vol / sum(volumes),
            rgba=front if part == "front" else list(obj.rgba),
            group=SCENE_GROUP,
            friction=list(FIXTURE_FRICTION),
        )


def _handle(drawer: mujoco.MjsBody, obj: DrawerObject) -> None:
    """The handle: an upright bar in front of the panel on two posts, and its site; a top-down gripper's fingers
    close around it (across y), the posts passing between them, and its hand stays clear of the panel."""
    _, d, h = obj.size
    t = WALL
    name = obj.name
    x0 = -d / 2  # the cabinet's front face
    bar_x = x0 - t - HANDLE_OFFSET
    half_len = min(0.04, 0.3 * h)
    metal = rgba(0.75, 0.75, 0.78)
    grip: dict[str, object] = {"rgba": metal, "group": SCENE_GROUP, "friction": [1.5, 0.02, 0.0001], "condim": 4}
    drawer.add_geom(
        name=f"{name}/handle",
        type=GEOM.mjGEOM_CAPSULE,
        fromto=[bar_x, 0, -half_len, bar_x, 0, half_len],
        size=[HANDLE_RADIUS, 0, 0],
        mass=0.1 * obj.mass,
        **grip,
    )
    for side, z in (("top", half_len), ("bottom", -half_len)):
        drawer.add_geom(
            name=f"{name}/post_{side}",
            type=GEOM.mjGEOM_BOX,
            size=[HANDLE_OFFSET / 2, 0.004, 0.004],
            pos=[x0 - t - HANDLE_OFFSET / 2, 0, z],
            mass=0.05 * obj.mass,
            **grip,
        )
    drawer.add_site(name=f"{name}/handle", pos=[bar_x, 0, 0], size=[0.005, 0, 0], group=3)
