"""`scene.params.randomize` of the native tabletop scenes: visual and physical variation drawn per episode.

Every value is drawn from the episode's seed (a generator of its own, so a scene without the block places its
objects exactly as before), stored in the episode's initial state under ``randomization`` and restored from
there by `replay`. What may vary, each within the stated bounds (a value outside them is a one-line error):

* ``light``: ``intensity`` (a factor on the light's diffuse colour, 0..4), ``color`` (each channel of that
  colour moved by up to this much, 0..1), ``direction`` (the light's direction tilted by up to this much in x
  and y, the direction being of unit length, 0..1);
* ``colors``: geoms whose colour is drawn uniformly per channel in 0.05..0.95 (``table``, ``floor`` or
  object names);
* ``textures``: geoms that get one of the shipped textures (`TEXTURES`; ``table``, ``floor`` or object names);
* ``cameras``: world cameras (``names``, default all of them) moved by up to ``pos`` metres per axis, their
  look-at point by up to ``lookat`` metres per axis, their field of view by up to ``fovy`` degrees; the camera
  intrinsics a dataset states are the nominal ones, the drawn ones are in the episode's provenance;
* ``physics``: for each of ``objects`` (box, sphere or cylinder objects for ``size``), a factor on its mass,
  on its sliding friction and on its size (inertia follows the size, placement the new extent);
* ``distractors``: between ``count[0]`` and ``count[1]`` extra objects (box, sphere, cylinder in turn; a
  colour and a size drawn per episode) placed after the declared objects in ``region`` (default the
  workspace); the ones an episode does not use are parked under the floor, weightless and without contacts.

``enabled: false`` keeps the block declared but draws nothing (``record --randomize on|off`` overrides it).
"""

from __future__ import annotations

from pydantic import Field, model_validator

from openral_data.schemas.base import StrictModel
from openral_data.schemas.tabletop import Range, XYRegion

__all__ = [
    "MAX_DISTRACTORS",
    "TEXTURES",
    "CameraJitter",
    "Distractors",
    "LightJitter",
    "PhysicsJitter",
    "Randomize",
]

MAX_DISTRACTORS = 8
# the shipped textures (MuJoCo builtin procedural textures, so no asset file is read): name -> (builtin, mark,
# rgb1, rgb2, repeat)
TEXTURES: dict[str, tuple[str, str, tuple[float, float, float], tuple[float, float, float], float]] = {
    "checker_grey": ("checker", "none", (0.35, 0.35, 0.35), (0.65, 0.65, 0.65), 8.0),
    "checker_blue": ("checker", "none", (0.15, 0.25, 0.55), (0.55, 0.65, 0.85), 6.0),
    "grid_light": ("flat", "edge", (0.85, 0.85, 0.8), (0.3, 0.3, 0.3), 10.0),
    "gradient_warm": ("gradient", "none", (0.8, 0.55, 0.3), (0.35, 0.2, 0.1), 1.0),
    "noise_sand": ("flat", "random", (0.75, 0.68, 0.5), (0.45, 0.38, 0.25), 4.0),
    "noise_dark": ("flat", "random", (0.25, 0.25, 0.28), (0.6, 0.6, 0.65), 4.0),
}


def _range(value: Range, name: str, lo: float, hi: float) -> None:
    if not lo <= value[0] <= value[1] <= hi:
        raise ValueError(f"{name}: [{value[0]}, {value[1]}] must be ordered and within {lo}..{hi}")


class LightJitter(StrictModel):
    intensity: Range | None = Field(default=None, description="factor on the diffuse colour")
    color: float = Field(default=0.0, ge=0, le=1, description="per-channel change of the diffuse colour, +-")
    direction: float = Field(default=0.0, ge=0, le=1, description="tilt of the unit direction in x and y, +-")

    @model_validator(mode="after")
    def _check(self) -> LightJitter:
        if self.intensity is not None:
            _range(self.intensity, "intensity", 0.0, 4.0)
        return self


class CameraJitter(StrictModel):
    names: list[str] | None = Field(default=None, description="world cameras to move (default: all)")
    pos: float = Field(default=0.0, ge=0, le=0.5, description="metres per axis, +-")
    lookat: float = Field(default=0.0, ge=0, le=0.5, description="metres per axis, +-")
    fovy: float = Field(default=0.0, ge=0, le=30, description="degrees, +-")


class PhysicsJitter(StrictModel):
    objects: list[str] = Field(min_length=1)
    mass: Range | None = Field(default=None, description="factor on the mass")
    friction: Range | None = Field(default=None, description="factor on the sliding friction")
    size: Range | None = Field(default=None, description="factor on the size (box, sphere, cylinder)")

    @model_validator(mode="after")
    def _check(self) -> PhysicsJitter:
        for name, lo, hi in (("mass", 0.05, 20.0), ("friction", 0.05, 20.0), ("size", 0.25, 4.0)):
            value = getattr(self, name)
            if value is not None:
                _range(value, name, lo, hi)
        return self


class Distractors(StrictModel):
    count: tuple[int, int] = Field(description="least and most distractors in an episode")
    size: Range = Field(default=(0.03, 0.05), description="box side / diameter, metres")
    region: XYRegion | None = Field(default=None, description="where they go (default: the workspace)")
    mass: float = Field(default=0.05, gt=0, le=5)

    @model_validator(mode="after")
    def _check(self) -> Distractors:
        lo, hi = self.count
        if not 0 <= lo <= hi <= MAX_DISTRACTORS:
            raise ValueError(f"count: [{lo}, {hi}] must be ordered and within 0..{MAX_DISTRACTORS}")
        _range(self.size, "size", 0.01, 0.2)
        return self


class Randomize(StrictModel):
    enabled: bool = True
    light: LightJitter | None = None
    colors: list[str] = Field(default_factory=list, description="geoms recoloured per episode")
    textures: list[str] = Field(default_factory=list, description="geoms given a shipped texture per episode")
    cameras: CameraJitter | None = None
    physics: PhysicsJitter | None = None
    distractors: Distractors | None = None
