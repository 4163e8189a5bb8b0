"""Compatibility of scene, robot and rSkill, checked before anything runs or is written."""

from __future__ import annotations

from typing import TYPE_CHECKING

from openral_data.errors import CompatibilityError, OpenralError
from openral_data.runtime.available import runnable
from openral_data.schemas.robot import RobotManifest
from openral_data.schemas.rskill import RSkillManifest
from openral_data.types import ProducerSpec

if TYPE_CHECKING:  # only an annotation: `list` (runtime.available) starts without the video/parquet stack
    from openral_data.formats.lerobot_v3.encoder import VideoSettings

# the policies that run on some scene types only: their experts read that simulator's ground truth
_TABLETOP = ("tabletop", "tabletop_push", "tabletop_pick_place")
_SCENE_TYPES = {"metaworld_expert": ("metaworld",), "maniskill_expert": ("maniskill",)}


def runs_on(rskill: RSkillManifest, scene_type: str) -> bool:
    """Whether `rskill`'s policy can drive a scene of `scene_type` (scripted experts need a MuJoCo tabletop)."""
    types = _TABLETOP if rskill.policy.startswith("scripted_") else _SCENE_TYPES.get(rskill.policy)
    return types is None or scene_type in types


def rskills_for(robot: RobotManifest, spec: ProducerSpec | None = None, scene_type: str | None = None) -> list[str]:
    """Ids of the rSkills on the search path that can run here: embodiment tags overlapping the robot's, (with
    `spec`) state and action sizes and required cameras what the scene has, (with `scene_type`) a policy that runs
    on that scene type, and a neural policy's checkpoint present (unreadable manifests skipped)."""
    from openral_data.runtime import registry

    fitting = []
    for rskill_id in registry.rskill_ids():
        try:
            manifest, _ = registry.resolve_rskill(rskill_id)
        except OpenralError:
            continue
        if not set(manifest.embodiment_tags) & set(robot.embodiment_tags) or (spec and not _fits(manifest, spec)):
            continue
        if (scene_type is None or runs_on(manifest, scene_type)) and runnable(manifest):
            fitting.append(rskill_id)
    return fitting


def _fits(rskill: RSkillManifest, spec: ProducerSpec) -> bool:
    return (
        spec.state_dim in (None, rskill.state_contract.dim)
        and spec.action_dim in (None, rskill.action_contract.dim)
        and all(c in spec.cameras for c in rskill.required_cameras)
    )


def _hint(robot: RobotManifest, spec: ProducerSpec | None = None, scene_type: str | None = None) -> str:
    fitting = rskills_for(robot, spec, scene_type)
    return f" (rSkills that fit: {', '.join(fitting)})" if fitting else ""


def check_compatibility(
    robot: RobotManifest,
    rskill: RSkillManifest,
    spec: ProducerSpec,
    *,
    rskill_source: str,
    scene_source: str,
    video: VideoSettings,
    scene_type: str | None = None,
) -> None:
    """Raise CompatibilityError naming the file and field of the first mismatch; the rSkills it suggests are those
    that can run (on `scene_type`, when given)."""
    if not set(rskill.embodiment_tags) & set(robot.embodiment_tags):
        # the spec was built for this rSkill, so only the robot's tags say which rSkills fit
        raise CompatibilityError(
            f"{rskill_source}: embodiment_tags: {rskill.embodiment_tags} share nothing with robot "
            f"{robot.name!r} tags {robot.embodiment_tags}" + _hint(robot, None, scene_type)
        )
    if spec.state_dim is not None and spec.state_dim != rskill.state_contract.dim:
        raise CompatibilityError(
            f"{rskill_source}: state_contract.dim: {rskill.state_contract.dim} but scene {scene_source} "
            f"produces a state of {spec.state_dim}" + _hint(robot, spec, scene_type)
        )
    if spec.action_dim is not None and spec.action_dim != rskill.action_contract.dim:
        raise CompatibilityError(
            f"{rskill_source}: action_contract.dim: {rskill.action_contract.dim} but scene {scene_source} "
            f"accepts actions of {spec.action_dim}" + _hint(robot, spec, scene_type)
        )
    missing = [c for c in rskill.required_cameras if c not in spec.cameras]
    if missing:
        raise CompatibilityError(
            f"{rskill_source}: required_cameras: {missing} not provided by scene {scene_source} "
            f"(it has {sorted(spec.cameras)})" + _hint(robot, spec, scene_type)
        )
    for name, shape in spec.cameras.items():
        problem = video.size_problem(shape.height, shape.width)
        if problem:
            raise CompatibilityError(f"{scene_source}: scene.cameras.{name}: {problem}")
