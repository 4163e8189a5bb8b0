"""MuJoCo wiring of a robot manifest (`sim:` block) and the parameters of the native tabletop scenes.

A robot manifest's `sim:` block says how its MJCF is driven, so no scene has per-robot Python: which MJCF
joints form the arm (in action/state order), the servo gains the scene gives them, the home posture, where the
gripper is attached (or that the arm MJCF carries it) and how its actuators map to one normalised value
(0 = open, 1 = closed), which site is the end effector, where a wrist camera goes, the default base pose, and
the units the manifest's joints speak (`units`: the twin HAL converts at its boundary).
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from openral_data.schemas.base import StrictModel
from openral_data.schemas.randomize import Randomize
from openral_data.schemas.tabletop import TableLayout, XYRegion

Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


class GripperWiring(StrictModel):
    """The manifest's `assets.gripper_mjcf` is attached at the arm's `attach_body`; without a gripper MJCF the
    names below are inside the arm MJCF (an arm with an integrated jaw, e.g. the SO-100/SO-101).

    Each actuator is driven linearly from `open` to `closed` by the normalised command g in [0, 1]; the state
    reports the mean of each joint's position mapped the same way from `joint_open` to `joint_closed`.
    """

    actuators: list[str] = Field(min_length=1)
    open: list[float]
    closed: list[float]
    joints: list[str] = Field(min_length=1)
    joint_open: list[float]
    joint_closed: list[float]
    ee_site: str = Field(min_length=1, description="site at the grasp centre (gripper MJCF, else arm MJCF)")

    @model_validator(mode="after")
    def _lengths(self) -> GripperWiring:
        if not (len(self.open) == len(self.closed) == len(self.actuators)):
            raise ValueError("open and closed need one value per entry of actuators")
        if not (len(self.joint_open) == len(self.joint_closed) == len(self.joints)):
            raise ValueError("joint_open and joint_closed need one value per entry of joints")
        return self


class WristCamera(StrictModel):
    body: str = Field(min_length=1, description="body of the arm (or gripper, prefixed 'gripper/') to mount on")
    pos: Vec3 = (0.0, 0.0, 0.0)
    quat: Quat = (1.0, 0.0, 0.0, 0.0)
    fovy: float = Field(default=75.0, gt=0, lt=180)


class ManifestUnits(StrictModel):
    """The units of the manifest's joints (its `joints:` limits, state and action) against the MJCF's.

    The twin HAL converts at its boundary, so the manifest's safety limits and the recorded data stay in the
    real robot's units: arm joints `degrees` -> radians (the same zero: a manifest whose zero differs from the
    MJCF's needs an MJCF that matches it), the gripper value `gripper_open` .. `gripper_closed` linearly onto the
    normalised 0 (open) .. 1 (closed) of `gripper`. The defaults are the MJCF's own units.
    """

    joints: Literal["radians", "degrees"] = "radians"
    gripper_open: float = 0.0
    gripper_closed: float = 1.0

    @model_validator(mode="after")
    def _distinct(self) -> ManifestUnits:
        if self.gripper_open == self.gripper_closed:
            raise ValueError("gripper_open and gripper_closed must differ")
        return self


class MujocoRobotWiring(StrictModel):
    """The `sim:` block of `robots/<id>/robot.yaml` for the MuJoCo backend (the MJCF is `assets.mjcf`)."""

    root_body: str = "base"
    arm_joints: list[str] = Field(min_length=1)
    home: list[float]
    kp: list[float]
    kv: list[float]
    armature: float = Field(default=0.1, ge=0)
    attach_body: str | None = Field(
        default=None, min_length=1, description="arm body the gripper MJCF is attached to (needed with one)"
    )
    gripper: GripperWiring
    wrist_camera: WristCamera | None = None
    base_pos: Vec3 = (0.0, 0.0, 0.0)
    units: ManifestUnits = Field(default_factory=ManifestUnits)
    tabletop: bool = Field(
        default=True, description="false: a twin only (record --hal); the tabletop scenes' workspace is out of reach"
    )

    @model_validator(mode="after")
    def _per_joint(self) -> MujocoRobotWiring:
        n = len(self.arm_joints)
        for key in ("home", "kp", "kv"):
            if len(getattr(self, key)) != n:
                raise ValueError(f"{key} needs one value per arm joint ({n}), got {len(getattr(self, key))}")
        if any(k <= 0 for k in self.kp) or any(k < 0 for k in self.kv):
            raise ValueError("kp must be > 0 and kv >= 0")
        return self


class TabletopParams(TableLayout):
    """`scene.params` of the native tabletop scenes: the table and robot placement here, the objects, workspace,
    clutter, success and roles from `TableLayout` (schemas/tabletop.py). The table top is at `table_height`."""

    task: str | None = Field(
        default=None,
        pattern=r"^[A-Za-z0-9_\-]+$",
        description="the task's label (scene type `tabletop`; default the scene id): recorded in the initial state",
    )
    table_height: float = Field(default=0.8, gt=0)
    table_size: tuple[float, float] = (1.2, 1.2)
    table_center: tuple[float, float] = (0.45, 0.0)
    base_pos: Vec3 | None = Field(default=None, description="robot base; default: manifest base_pos on the table")
    base_yaw: float = 0.0
    timestep: float = Field(default=0.002, gt=0, le=0.01)
    ready_xy: tuple[float, float] = (0.38, 0.0)
    ready_height: float = Field(default=0.25, gt=0, description="start: grasp site this far above the table")
    randomize: Randomize | None = Field(default=None, description="per-episode variation (schemas/randomize.py)")

    @property
    def table_top(self) -> XYRegion:
        """The table top's x/y extent (world frame)."""
        (cx, cy), (sx, sy) = self.table_center, self.table_size
        return XYRegion(x=(cx - sx / 2, cx + sx / 2), y=(cy - sy / 2, cy + sy / 2))
