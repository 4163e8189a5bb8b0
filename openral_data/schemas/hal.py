"""Hardware-facing parts of a robot manifest: the `safety:` block and the `hardware:` block.

`safety` bounds every command a HAL sends (joint limits and velocity limits come from `joints`; the workspace
box is checked on the end effector with the robot's MuJoCo twin). `hardware` says how to reach the real robot
(which driver, which serial port, where the calibration lives); each driver validates its own fields.
"""

from __future__ import annotations

from typing import Any, Literal

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


LerobotDevice = dict[str, Any]  # `type:` (lerobot's registered name) + that type's config fields


class HardwareConfig(StrictModel):
    """`hardware:` of `robots/<id>/robot.yaml`: the real robot's driver and how to reach it.

    `driver: lerobot` names any `lerobot.robots` type and its config in `robot:` ({type: koch_follower, port:
    ..., id: ..., calibration_dir: ...}); the SO drivers are the same with the SO follower's fields at the top
    level. `cameras:` (name -> a `lerobot.cameras` config: {type: opencv, index_or_path: ..., width, height,
    fps}) and `teleop:` (a `lerobot.teleoperators` config, e.g. {type: so101_leader, port: ..., id: ...}) go
    with either. lerobot validates each config itself (producers/hal/robots/lerobot_hw.py); a `calibration_dir` is
    relative to the manifest.
    """

    driver: Literal["lerobot", "lerobot_so100_follower", "lerobot_so101_follower"]
    port: str | None = Field(default=None, min_length=1, description="serial port of the motor bus, e.g. /dev/ttyACM0")
    id: str = Field(default="follower", min_length=1, description="lerobot robot id: names the calibration file")
    calibration_dir: str | None = Field(default=None, description="folder of <id>.json (default: lerobot's)")
    max_relative_target: float | None = Field(default=None, gt=0, description="lerobot's per-step target limit")
    use_degrees: bool = Field(default=True, description="joints in degrees (lerobot default), else -100..100")
    robot: LerobotDevice | None = Field(default=None, description="driver lerobot: the lerobot robot config")
    cameras: dict[str, LerobotDevice] = Field(default_factory=dict, description="lerobot camera configs by name")
    teleop: LerobotDevice | None = Field(default=None, description="the lerobot teleoperator config (a leader arm)")

    @model_validator(mode="after")
    def _reachable(self) -> HardwareConfig:
        if self.driver == "lerobot":
            if self.robot is None or not isinstance(self.robot.get("type"), str):
                raise ValueError("driver lerobot needs robot: {type: <a lerobot.robots type>, ...}")
        elif self.port is None:
            raise ValueError(f"driver {self.driver} needs port")
        for what, device in [("teleop", self.teleop), *((f"cameras.{n}", c) for n, c in self.cameras.items())]:
            if device is not None and not isinstance(device.get("type"), str):
                raise ValueError(f"{what} needs type: <a lerobot type name>")
        return self

    def robot_config(self) -> LerobotDevice:
        """The lerobot robot config: `robot:`, or the SO follower's from the top-level fields."""
        if self.robot is not None:
            return dict(self.robot)
        kind = self.driver.removeprefix("lerobot_")
        return {
            "type": kind, "port": self.port, "id": self.id, "calibration_dir": self.calibration_dir,
            "max_relative_target": self.max_relative_target, "use_degrees": self.use_degrees,
        }  # fmt: skip
