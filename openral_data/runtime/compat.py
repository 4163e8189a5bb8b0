"""Compatibility of scene, robot and rSkill, checked before anything runs or is written."""

from __future__ import annotations

from openral_data.errors import CompatibilityError, OpenralError
from openral_data.formats.lerobot_v3.encoder import VideoSettings
from openral_data.schemas.robot import RobotManifest
from openral_data.schemas.rskill import RSkillManifest
from openral_data.types import ProducerSpec


def rskills_for(robot: RobotManifest, spec: ProducerSpec | None = None) -> list[str]:
    """Ids of the shipped rSkills whose embodiment tags overlap the robot's and (with `spec`) whose state and
    action sizes and required cameras are what the scene has (unreadable manifests skipped)."""
    from openral_data.runtime import registry

    fitting = []
    for rskill_id in registry.rskill_ids():
        try:
            manifest, _ = registry.resolve_rskill(rskill_id)
        except OpenralError:
            continue
        if set(manifest.embodiment_tags) & set(robot.embodiment_tags) and (spec is None or _fits(manifest, spec)):
            fitting.append(rskill_id)
    return fitting


def _fits(rskill: RSkillManifest, spec: ProducerSpec) -> bool:
    return (
        spec.state_dim in (None, rskill.state_contract.dim)
        and spec.action_dim in (None, rskill.action_contract.dim)
        and all(c in spec.cameras for c in rskill.required_cameras)
    )


def _hint(robot: RobotManifest, spec: ProducerSpec | None = None) -> str:
    fitting = rskills_for(robot, spec)
    return f" (rSkills that fit: {', '.join(fitting)})" if fitting else ""


def check_compatibility(
    robot: RobotManifest,
    rskill: RSkillManifest,
    spec: ProducerSpec,
    *,
    rskill_source: str,
    scene_source: str,
    video: VideoSettings,
) -> None:
    """Raise CompatibilityError naming the file and field of the first mismatch."""
    if not set(rskill.embodiment_tags) & set(robot.embodiment_tags):
        # the spec was built for this rSkill, so only the robot's tags say which rSkills fit
        raise CompatibilityError(
            f"{rskill_source}: embodiment_tags: {rskill.embodiment_tags} share nothing with robot "
            f"{robot.name!r} tags {robot.embodiment_tags}" + _hint(robot)
        )
    if spec.state_dim is not None and spec.state_dim != rskill.state_contract.dim:
        raise CompatibilityError(
            f"{rskill_source}: state_contract.dim: {rskill.state_contract.dim} but scene {scene_source} "
            f"produces a state of {spec.state_dim}" + _hint(robot, spec)
        )
    if spec.action_dim is not None and spec.action_dim != rskill.action_contract.dim:
        raise CompatibilityError(
            f"{rskill_source}: action_contract.dim: {rskill.action_contract.dim} but scene {scene_source} "
            f"accepts actions of {spec.action_dim}" + _hint(robot, spec)
        )
    missing = [c for c in rskill.required_cameras if c not in spec.cameras]
    if missing:
        raise CompatibilityError(
            f"{rskill_source}: required_cameras: {missing} not provided by scene {scene_source} "
            f"(it has {sorted(spec.cameras)})" + _hint(robot, spec)
        )
    for name, shape in spec.cameras.items():
        problem = video.size_problem(shape.height, shape.width)
        if problem:
            raise CompatibilityError(f"{scene_source}: scene.cameras.{name}: {problem}")
