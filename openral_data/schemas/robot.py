"""Robot manifest: `robots/<id>/robot.yaml`."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from openral_data.schemas.base import StrictModel
from openral_data.schemas.hal import HardwareConfig, SafetyConfig
from openral_data.schemas.scene import MAX_CAMERA_SIDE

JointType = Literal["revolute", "prismatic", "continuous", "gripper"]


class Joint(StrictModel):
    name: str = Field(min_length=1)
    type: JointType
    limits: tuple[float, float] | None = None
    velocity_limit: float | None = Field(default=None, gt=0)

    @model_validator(mode="after")
    def _ordered(self) -> Joint:
        if self.limits is not None and self.limits[0] > self.limits[1]:
            raise ValueError(f"limits must be [lower, upper], got {list(self.limits)}")
        return self


class EndEffector(StrictModel):
    name: str = Field(min_length=1)
    type: Literal["parallel_gripper", "suction", "hand", "tool", "none"] = "parallel_gripper"
    joints: list[str] = Field(default_factory=list)
    site: str | None = None


class CameraSensor(StrictModel):
    name: str = Field(min_length=1, pattern=r"^[A-Za-z0-9_]+$")
    width: int = Field(gt=0, le=MAX_CAMERA_SIDE)
    height: int = Field(gt=0, le=MAX_CAMERA_SIDE)
    mount: Literal["world", "wrist", "head", "base"] = "world"


class Sensors(StrictModel):
    cameras: list[CameraSensor] = Field(default_factory=list)


class VectorSpec(StrictModel):
    """A named float vector the robot exposes (state) or accepts (action)."""

    dim: int = Field(gt=0)
    names: list[str] | None = None

    @model_validator(mode="after")
    def _names_match(self) -> VectorSpec:
        if self.names is not None and len(self.names) != self.dim:
            raise ValueError(f"names has {len(self.names)} entries but dim is {self.dim}")
        return self


class ObservationSpec(StrictModel):
    state: VectorSpec


class Assets(StrictModel):
    """Where the robot's model comes from. `mjcf` is `pkg://<python package>/<path>`, `share://<path>` (a wheel's data
    files under the environment's `share/`) or a repo-relative path."""

    mjcf: str | None = None
    gripper_mjcf: str | None = None


class RobotManifest(StrictModel):
    name: str = Field(min_length=1, pattern=r"^[A-Za-z0-9_\-]+$")
    description: str = ""
    embodiment_tags: list[str] = Field(min_length=1)
    joints: list[Joint] = Field(default_factory=list)
    end_effectors: list[EndEffector] = Field(default_factory=list)
    sensors: Sensors = Field(default_factory=Sensors)
    observation: ObservationSpec
    action: VectorSpec
    assets: Assets = Field(default_factory=Assets)
    sim: dict[str, object] | None = None  # backend-specific wiring, validated by the backend that reads it
    safety: SafetyConfig = Field(default_factory=SafetyConfig)  # bounds on HAL commands (producers/hal)
    hardware: HardwareConfig | None = None  # how to reach the real robot (record --hal ID --mode real)

    @model_validator(mode="after")
    def _unique_names(self) -> RobotManifest:
        for what, names in (
            ("joints", [j.name for j in self.joints]),
            ("sensors.cameras", [c.name for c in self.sensors.cameras]),
        ):
            dup = sorted({n for n in names if names.count(n) > 1})
            if dup:
                raise ValueError(f"duplicate {what} names: {dup}")
        known = {j.name for j in self.joints}
        for ee in self.end_effectors:
            missing = [j for j in ee.joints if j not in known]
            if missing:
                raise ValueError(f"end effector {ee.name!r} names unknown joints {missing}")
        return self
