"""rSkill manifest: `rskills/<id>/rskill.yaml` — a policy plus the state/action contract it speaks."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from openral_data.schemas.base import StrictModel

Representation = Literal[
    "joint_positions",
    "joint_velocities",
    "joint_positions_gripper",
    "eef_pose",
    "delta_eef_gripper",
    "eef_pose_gripper",
    "eef_pose_gripper_width",
    "generic",
]


class Contract(StrictModel):
    """What one side of the policy interface carries: a float32 vector of `dim` named entries."""

    dim: int = Field(gt=0)
    dtype: Literal["float32"] = "float32"
    names: list[str]
    representation: Representation = "generic"
    low: list[float] | None = None
    high: list[float] | None = None

    @model_validator(mode="after")
    def _consistent(self) -> Contract:
        if len(self.names) != self.dim:
            raise ValueError(f"names has {len(self.names)} entries but dim is {self.dim}")
        if len(set(self.names)) != len(self.names):
            raise ValueError("names must be unique")
        for key in ("low", "high"):
            bound = getattr(self, key)
            if bound is not None and len(bound) != self.dim:
                raise ValueError(f"{key} has {len(bound)} entries but dim is {self.dim}")
        if (
            self.low is not None
            and self.high is not None
            and any(lo > hi for lo, hi in zip(self.low, self.high, strict=True))
        ):
            raise ValueError("low must be <= high in every dimension")
        return self


class RSkillManifest(StrictModel):
    id: str = Field(min_length=1, pattern=r"^[A-Za-z0-9_\-.]+$")
    description: str = ""
    policy: str = Field(min_length=1)
    embodiment_tags: list[str] = Field(min_length=1)
    state_contract: Contract
    action_contract: Contract
    required_cameras: list[str] = Field(default_factory=list)
    policy_extras: dict[str, object] = Field(default_factory=dict)
