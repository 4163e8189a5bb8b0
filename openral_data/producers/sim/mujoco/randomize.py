"""Per-episode visual and physical variation of a tabletop scene (`scene.params.randomize`, schemas/randomize.py).

Three steps, all on the compiled model (no recompiling per episode):

* at composition, `objects.add_textures` adds the shipped textures as materials and `distractor_objects` the
  distractor bodies the block may use (so a scene's model is the same whether the block is on or off);
* `Randomizer.draw(seed)` draws an episode's values from a generator of its own (`[seed, SALT]`: the placement
  generator of the scene is untouched, so objects land where they did without the block) and returns them as
  plain JSON, the episode's provenance;
* `Randomizer.apply(values)` first restores every nominal value it may change, then writes `values`: replay
  applies the values an episode recorded, whatever the block says now.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from openral_data.errors import ConfigError
from openral_data.producers.sim.mujoco.compose import look_at_quat
from openral_data.producers.sim.mujoco.objects import MATERIAL_PREFIX
from openral_data.producers.sim.mujoco.placement import primitive
from openral_data.schemas.randomize import TEXTURES, Distractors, Randomize
from openral_data.schemas.scene import SceneCamera
from openral_data.schemas.tabletop import (
    Pose,
    TabletopObject,
    Workspace,
    XYRegion,
)

__all__ = ["DISTRACTOR_PREFIX", "SALT", "Randomizer", "distractor_objects"]

SALT = 0x52414E44  # "RAND": the randomization generator is default_rng([seed, SALT])
DISTRACTOR_PREFIX = "distractor_"
PARKED_Z = -5.0  # parked distractors wait here, under the floor
F64 = npt.NDArray[np.float64]
_KINDS = ("box", "sphere", "cylinder")


def distractor_objects(d: Distractors | None, area: XYRegion | Workspace) -> list[TabletopObject]:
    """The most distractors the block may place (box, sphere, cylinder in turn, at their largest size)."""
    if d is None:
        return []
    region = d.region or area
    out: list[TabletopObject] = []
    s = d.size[1]
    for k in range(d.count[1]):
        common: dict[str, Any] = {
            "name": f"{DISTRACTOR_PREFIX}{k}",
            "mass": d.mass,
            "rgba": (0.5, 0.5, 0.5, 1.0),
            "pose": Pose(x=region.x, y=region.y, yaw=(-np.pi, np.pi)),
        }
        out.append(primitive(_KINDS[k % len(_KINDS)], s, common))
    return out


def _u(rng: np.random.Generator, lo: float, hi: float) -> float:
    return round(float(rng.uniform(lo, hi)), 6)


class Randomizer:
    """Draws and applies an episode's variation on `model` (see the module). `spec` None: nothing varies, and
    `apply` still restores the nominal model (an episode recorded with variation replayed on the same scene)."""

    def __init__(
        self,
        model: mujoco.MjModel,
        spec: Randomize | None,
        objects: Sequence[TabletopObject],
        cameras: Sequence[SceneCamera],
        source: str,
    ) -> None:
        self.model = model
        self.spec = spec
        self.source = f"{source}: scene.params.randomize"
        self.objects = {o.name: o for o in objects}
        self.world_cameras = {c.name: c for c in cameras if c.mount == "world"}
        m = model
        self._geoms = {"table": [m.geom("table").id], "floor": [m.geom("floor").id]}
        for obj in objects:
            bid = m.body(obj.name).id
            self._geoms[obj.name] = [g for g in range(m.ngeom) if m.geom_bodyid[g] == bid]
        self.distractors = [o.name for o in objects if o.name.startswith(DISTRACTOR_PREFIX)]
        self._cameras = {m.camera(c).name: c for c in range(m.ncam)}
        self._check()
        # the nominal values `apply` restores first
        self._nominal = {
            name: np.array(getattr(m, name), copy=True)
            for name in (
                "light_diffuse",
                "light_dir",
                "geom_rgba",
                "geom_matid",
                "geom_size",
                "geom_friction",
                "geom_contype",
                "geom_conaffinity",
                "geom_rbound",
                "geom_aabb",
                "body_mass",
                "body_inertia",
                "body_gravcomp",
                "cam_pos",
                "cam_quat",
                "cam_fovy",
            )
        }

    @property
    def names(self) -> list[str]:
        """What `colors` / `textures` may name: the table, the floor and every object."""
        return sorted(self._geoms)

    def rgba(self, name: str) -> list[float]:
        """The current (this episode's) rgba of `name`'s first geom."""
        return [float(v) for v in self.model.geom_rgba[self._geoms[name][0]]]

    # -- checks ----------------------------------------------------------------------------------------------
    def _check(self) -> None:
        spec = self.spec
        if spec is None:
            return
        known = sorted(self._geoms)
        for field in ("colors", "textures"):
            for k, name in enumerate(getattr(spec, field)):
                if name not in self._geoms:
                    raise ConfigError(f"{self.source}.{field}[{k}]: no geom {name!r} (one of: {', '.join(known)})")
        if spec.cameras is not None and spec.cameras.names is not None:
            for k, name in enumerate(spec.cameras.names):
                if name not in self.world_cameras:
                    raise ConfigError(
                        f"{self.source}.cameras.names[{k}]: no world camera {name!r} "
                        f"(one of: {', '.join(self.world_cameras) or 'none'})"
                    )
        if spec.physics is not None:
            for k, name in enumerate(spec.physics.objects):
                obj = self.objects.get(name)
                if obj is None or not obj.is_movable:
                    raise ConfigError(f"{self.source}.physics.objects[{k}]: no movable object {name!r}")
                if spec.physics.size is not None and obj.kind not in _KINDS:
                    raise ConfigError(
                        f"{self.source}.physics.objects[{k}]: {name!r} is a {obj.kind}; size varies only for "
                        "box, sphere and cylinder objects"
                    )

    # -- drawing ---------------------------------------------------------------------------------------------
    def draw(self, seed: int) -> dict[str, Any]:
        """An episode's values (plain JSON: lists, floats, ints, strings); {} when nothing varies."""
        spec = self.spec
        if spec is None or not spec.enabled:
            return {}
        rng = np.random.default_rng([seed, SALT])
        out: dict[str, Any] = {}
        if spec.light is not None:
            out["light"] = self._draw_light(rng)
        if spec.colors:
            out["colors"] = {n: [*(_u(rng, 0.05, 0.95) for _ in range(3)), 1.0] for n in spec.colors}
        if spec.textures:
            names = sorted(TEXTURES)
            out["textures"] = {n: names[int(rng.integers(len(names)))] for n in spec.textures}
        if spec.cameras is not None:
            out["cameras"] = self._draw_cameras(rng)
        if spec.physics is not None:
            p = spec.physics
            out["physics"] = {
                name: {
                    key: _u(rng, *rng_range)
                    for key, rng_range in (("mass", p.mass), ("friction", p.friction), ("size", p.size))
                    if rng_range is not None
                }
                for name in p.objects
            }
        if spec.distractors is not None:
            d = spec.distractors
            n = int(rng.integers(d.count[0], d.count[1] + 1))
            out["distractors"] = {
                "count": n,
                "objects": {
                    name: {
                        "rgba": [*(_u(rng, 0.05, 0.95) for _ in range(3)), 1.0],
                        "size": round(_u(rng, *d.size) / d.size[1], 6),
                    }
                    for name in self.distractors[:n]
                },
            }
        return out

    def _draw_light(self, rng: np.random.Generator) -> dict[str, Any]:
        spec = self.spec
        assert spec is not None and spec.light is not None
        lj = spec.light
        diffuse = self._nominal["light_diffuse"][0].astype(np.float64)
        if lj.intensity is not None:
            diffuse = diffuse * _u(rng, *lj.intensity)
        if lj.color:
            diffuse = diffuse + np.array([_u(rng, -lj.color, lj.color) for _ in range(3)])
        direction = self._nominal["light_dir"][0].astype(np.float64)
        direction = direction / np.linalg.norm(direction)
        if lj.direction:
            direction = direction + np.array([_u(rng, -lj.direction, lj.direction) for _ in range(2)] + [0.0])
            direction /= np.linalg.norm(direction)
        return {
            "diffuse": [round(float(v), 6) for v in np.clip(diffuse, 0.0, 1.0)],
            "dir": [round(float(v), 6) for v in direction],
        }

    def _draw_cameras(self, rng: np.random.Generator) -> dict[str, Any]:
        spec = self.spec
        assert spec is not None and spec.cameras is not None
        cj = spec.cameras
        out: dict[str, Any] = {}
        for name in cj.names or list(self.world_cameras):
            cam = self.world_cameras[name]
            assert cam.pos is not None and cam.lookat is not None  # world cameras have both (compose checks)
            out[name] = {
                "pos": [round(v + _u(rng, -cj.pos, cj.pos), 6) for v in cam.pos],
                "lookat": [round(v + _u(rng, -cj.lookat, cj.lookat), 6) for v in cam.lookat],
                "fovy": round(cam.fovy + _u(rng, -cj.fovy, cj.fovy), 6),
            }
        return out

    # -- applying --------------------------------------------------------------------------------------------
    def apply(self, values: dict[str, Any]) -> None:
        """Restore the nominal model, then write `values` (an episode's `draw`, possibly read back from JSON)."""
        m = self.model
        for name, value in self._nominal.items():
            getattr(m, name)[...] = value
        try:
            self._apply(values)
        except (KeyError, TypeError, ValueError, IndexError) as exc:
            raise ConfigError(f"initial_state: randomization: does not fit this scene: {exc!r}") from None
        for name in self.parked(values):
            self._park(name)

    def _apply(self, values: dict[str, Any]) -> None:  # one short block per kind of variation
        m = self.model
        light = values.get("light")
        if light is not None:
            m.light_diffuse[0] = light["diffuse"]
            m.light_dir[0] = light["dir"]
        for name, rgba in values.get("colors", {}).items():
            for g in self._geoms[name]:
                m.geom_rgba[g] = rgba
        for name, texture in values.get("textures", {}).items():
            mat = m.material(f"{MATERIAL_PREFIX}{texture}").id
            for g in self._geoms[name]:
                m.geom_matid[g] = mat
                if name not in values.get("colors", {}):
                    m.geom_rgba[g] = [1.0, 1.0, 1.0, 1.0]  # the texture's own colours
        for name, cam in values.get("cameras", {}).items():
            if name not in self._cameras:
                continue  # a scene built without its cameras (replay that renders nothing)
            cid = self._cameras[name]
            m.cam_pos[cid] = cam["pos"]
            m.cam_quat[cid] = look_at_quat(cam["pos"], cam["lookat"])
            m.cam_fovy[cid] = cam["fovy"]
        for name, phys in values.get("physics", {}).items():
            self._scale(name, phys.get("mass", 1.0), phys.get("friction", 1.0), phys.get("size", 1.0))
        for name, dist in values.get("distractors", {}).get("objects", {}).items():
            self._scale(name, 1.0, 1.0, float(dist["size"]))
            for g in self._geoms[name]:
                m.geom_rgba[g] = dist["rgba"]

    def _scale(self, name: str, mass: float, friction: float, size: float) -> None:
        m, bid = self.model, self.model.body(name).id
        m.body_mass[bid] = self._nominal["body_mass"][bid] * mass
        m.body_inertia[bid] = self._nominal["body_inertia"][bid] * mass * size**2
        for g in self._geoms[name]:
            m.geom_friction[g, 0] = self._nominal["geom_friction"][g, 0] * friction
            m.geom_size[g] = self._nominal["geom_size"][g] * size
            m.geom_rbound[g] = self._nominal["geom_rbound"][g] * size
            m.geom_aabb[g] = self._nominal["geom_aabb"][g] * size

    def _park(self, name: str) -> None:
        """A distractor this episode does not use: weightless, without contacts, invisible."""
        m, bid = self.model, self.model.body(name).id
        m.body_gravcomp[bid] = 1.0
        for g in self._geoms[name]:
            m.geom_contype[g] = 0
            m.geom_conaffinity[g] = 0
            m.geom_rgba[g, 3] = 0.0

    def parked(self, values: dict[str, Any]) -> list[str]:
        """The distractors an episode with `values` parks."""
        used = values.get("distractors", {}).get("objects", {})
        return [n for n in self.distractors if n not in used]

    @staticmethod
    def parked_pos(k: int) -> F64:
        return np.array([-2.0 + 0.3 * k, -2.0, PARKED_Z], dtype=np.float64)
