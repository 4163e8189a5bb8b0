"""A state against its robot's manifest (`robots/<id>/robot.yaml`, found on the manifest search path by the
dataset's robot: our provenance's, else info.json's `robot_type`), each a list of `Finding`s with frames: a joint
outside its declared `limits` (`joint_limit`) and a joint moving faster between two frames than its declared
`velocity_limit` (`joint_velocity`) (docs/stats.md, "Quality").

A state dimension is a manifest joint when its name is the joint's, or the joint's with a `.pos`/`_pos`/
`.position` suffix (LeRobot's Feetech arms name their state `shoulder_pan.pos`). The manifest's units are the
dataset's: our recordings write what the manifest declares; a foreign dataset of another robot type matches no
manifest and is not checked.
"""

from __future__ import annotations

import functools
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from openral_data import manifests
from openral_data.errors import OpenralError
from openral_data.formats.lerobot_v3.features import STATE
from openral_data.metrics.quality.findings import Finding, dim_subject, runs, span_findings
from openral_data.metrics.quality.thresholds import Thresholds
from openral_data.schemas.base import load_model
from openral_data.schemas.robot import Joint, RobotManifest

Array = npt.NDArray[np.float64]
SUFFIX = re.compile(r"[._](pos|position)$", re.IGNORECASE)


@dataclass(frozen=True)
class Joints:
    """The manifest joints a state's dimensions are: dimension -> joint."""

    by_dim: dict[int, Joint]

    def revolute(self) -> frozenset[int]:
        """The dimensions that are revolute or continuous joints (angles)."""
        return frozenset(d for d, j in self.by_dim.items() if j.type in ("revolute", "continuous"))


def manifest_joints(robot: str) -> tuple[Joint, ...]:
    """The joints robot `robot`'s manifest declares (none when there is no such manifest, or it does not load: a
    quality scan never fails on a manifest)."""
    try:
        path = manifests.find("robots", robot)
        return () if path is None else loaded(path, path.stat().st_mtime_ns)
    except (OpenralError, OSError, ValueError):
        return ()


@functools.lru_cache(maxsize=32)
def loaded(path: Path, mtime_ns: int) -> tuple[Joint, ...]:
    """A manifest's joints, read once per version of its file (`mtime_ns`)."""
    return tuple(load_model(RobotManifest, path).joints)


def robot_joints(robot: str | None, names: list[str]) -> Joints:
    """The dimensions of a state named `names` that are joints of `robot`'s manifest."""
    if not robot:
        return Joints({})
    joints = {j.name.lower(): j for j in manifest_joints(robot)}
    found = {d: joints.get(SUFFIX.sub("", name).lower()) for d, name in enumerate(names)}
    return Joints({d: j for d, j in found.items() if j is not None})


def joint_limits(x: Array, joints: Joints, names: list[str], feature: str, th: Thresholds) -> list[Finding]:
    """`joint_limit`: each run of frames where a joint's state is beyond its manifest `limits` by more than
    `limit_margin` of the joint's range (a reading past a hard stop: a wrong calibration, a wrong unit, a
    corrupted value); value: the largest excess, as a share of the range."""
    out: list[Finding] = []
    for d, joint in sorted(joints.by_dim.items()):
        if joint.limits is None or not joint.limits[1] > joint.limits[0]:
            continue
        lo, hi = joint.limits
        with np.errstate(invalid="ignore"):
            excess = np.fmax(lo - x[:, d], x[:, d] - hi) / (hi - lo)
        bad = np.nan_to_num(excess, nan=0.0) > th.limit_margin
        if bad.any():
            detail = f"outside [{lo:g}, {hi:g}]"
            worst = float(np.nanmax(excess[bad]))
            out += span_findings(
                "joint_limit", dim_subject(feature, names[d]), runs(bad), worst, th.limit_margin, detail=detail
            )
    return out


def joint_velocities(
    x: Array, joints: Joints, names: list[str], feature: str, periods: Array, fps: int, th: Thresholds
) -> list[Finding]:
    """`joint_velocity`: each frame where a joint's state moved since the previous frame faster than
    `velocity_factor` times its manifest `velocity_limit` (the step over the time the timestamps say passed,
    `periods` in frame periods: a late frame had longer to move); value: the velocity over the limit."""
    if len(x) < 2:
        return []
    dt = np.where(periods > 0, periods, np.nan) / fps
    out: list[Finding] = []
    for d, joint in sorted(joints.by_dim.items()):
        if joint.velocity_limit is None:
            continue
        with np.errstate(invalid="ignore"):
            ratio = np.abs(np.diff(x[:, d])) / dt / joint.velocity_limit
        bad = np.nan_to_num(ratio, nan=0.0) > th.velocity_factor
        if bad.any():
            detail = f"limit {joint.velocity_limit:g}/s"
            worst = float(np.nanmax(ratio[bad])) if np.isfinite(ratio[bad]).any() else math.inf
            spans = [(a + 1, b + 1) for a, b in runs(bad)]  # step t: frame t to t + 1, found at the frame it reaches
            out += span_findings(
                "joint_velocity", dim_subject(feature, names[d]), spans, worst, th.velocity_factor, detail=detail
            )
    return out


def joint_findings(
    x: Array, robot: str | None, names: list[str], periods: Array, fps: int, th: Thresholds
) -> list[Finding]:
    """`joint_limit` and `joint_velocity` of a state `x` (dimensions `names`) against `robot`'s manifest."""
    joints = robot_joints(robot, names)
    if not joints.by_dim:
        return []
    return joint_limits(x, joints, names, STATE, th) + joint_velocities(x, joints, names, STATE, periods, fps, th)
