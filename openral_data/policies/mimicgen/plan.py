"""What the generator policy replays: source demonstrations cut into object-centric segments (a JSON file that
`openral-data generate` writes and the `mimicgen` rSkill's `policy_extras.plan` names).

A segment holds the end-effector target poses the source commanded over its frames, its gripper commands, the
object it is relative to, and that object's pose when the segment began in the source. The file is read as
untrusted input (bounded, validated; nothing in it chooses code).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pydantic import Field, model_validator

from openral_data.formats.jsonfile import read_json
from openral_data.policies.mimicgen.poses import F64, Pose
from openral_data.schemas.base import StrictModel, validate

MAX_SEGMENT_FRAMES = 100_000
Vec3 = tuple[float, float, float]
Quat = tuple[float, float, float, float]


class Segment(StrictModel):
    start: int = Field(ge=0)
    end: int = Field(gt=0)
    object: str = Field(min_length=1)
    object_pos: Vec3
    object_quat: Quat
    target_pos: list[Vec3] = Field(min_length=1, max_length=MAX_SEGMENT_FRAMES)
    target_quat: list[Quat] = Field(min_length=1, max_length=MAX_SEGMENT_FRAMES)
    gripper: list[float] = Field(min_length=1, max_length=MAX_SEGMENT_FRAMES)

    @model_validator(mode="after")
    def _check(self) -> Segment:
        n = self.end - self.start
        if n < 1 or not len(self.target_pos) == len(self.target_quat) == len(self.gripper) == n:
            raise ValueError(f"frames {self.start}..{self.end}: target_pos/target_quat/gripper need {n} rows each")
        for q in (self.object_quat, *self.target_quat):
            norm = float(np.linalg.norm(q))
            if not np.isfinite(norm) or norm < 1e-6:
                raise ValueError(f"quaternion {list(q)}: not of unit length")
        if not np.isfinite(np.array([self.object_pos, *self.target_pos])).all():
            raise ValueError("positions must be finite")
        return self

    def object_pose(self) -> Pose:
        return np.array(self.object_pos), _unit(np.array(self.object_quat))

    def targets(self) -> list[Pose]:
        return [(np.array(p), _unit(np.array(q))) for p, q in zip(self.target_pos, self.target_quat, strict=True)]


class Demo(StrictModel):
    episode: int = Field(ge=0)
    segments: list[Segment] = Field(min_length=1)


class Plan(StrictModel):
    source: str  # the source dataset (provenance)
    interpolation: int = Field(default=5, ge=0, le=200, description="steps between two segments")
    demos: list[Demo] = Field(min_length=1)


def _unit(q: F64) -> F64:
    return q / float(np.linalg.norm(q))  # validated: finite, not near zero


def read_plan(path: Path) -> Plan:
    return validate(Plan, read_json(path), str(path))


def write_plan(plan: Plan, path: Path) -> None:
    path.write_text(plan.model_dump_json())
