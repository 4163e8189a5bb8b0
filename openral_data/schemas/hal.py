"""Hardware-facing parts of a robot manifest: the `safety:` block and the `hardware:` block.

`safety` bounds every command a HAL sends (joint limits and velocity limits come from `joints`; the workspace
box is checked on the end effector with the robot's MuJoCo twin). `hardware` says how to reach the real robot
(which driver, which serial port, where the calibration lives); each driver validates its own fields.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from openral_data.schemas.base import StrictModel

SafetyMode = Literal["clamp", "refuse"]


class Workspace(StrictModel):
    """An axis-aligned box (metres) the end effector must stay in, in the frame of the robot's base."""

    x: tuple[float, float]
    y: tuple[float, float]
    z: tuple[float, float]

    @model_validator(mode="after")
    def _ordered(self) -> Workspace:
        for axis in ("x", "y", "z"):
            lo, hi = getattr(self, axis)
            if lo > hi:
                raise ValueError(f"{axis} must be [low, high], got {[lo, hi]}")
        return self


class SafetyConfig(StrictModel):
    mode: SafetyMode = Field(default="clamp", description="clamp out-of-bounds commands, or refuse (hold) them")
    workspace: Workspace | None = None
    max_state_age: float = Field(default=0.1, gt=0, description="seconds: an older joint reading is stale")


class HardwareConfig(StrictModel):
    """`hardware:` of `robots/<id>/robot.yaml`: the real robot's driver and how to reach it."""

    driver: Literal["lerobot_so100_follower", "lerobot_so101_follower"]
    port: str = Field(min_length=1, description="serial port of the motor bus, e.g. /dev/ttyACM0")
    id: str = Field(default="follower", min_length=1, description="lerobot robot id: names the calibration file")
    calibration_dir: str | None = Field(default=None, description="folder of <id>.json (default: lerobot's)")
    max_relative_target: float | None = Field(default=None, gt=0, description="lerobot's per-step target limit")
    use_degrees: bool = Field(default=True, description="joints in degrees (lerobot default), else -100..100")
