"""`--teleop expert` (producers/hal/teleop/expert.py): which rSkill the expert runs, resolved and checked once.

The expert is an rSkill (`expert`, else the scene's default rSkill: the scripted expert whose demos the policy
learned from); its actions must be the ones the driving policy's contract names, as a person's device's are."""

from __future__ import annotations

from openral_data.errors import ConfigError, UsageError
from openral_data.producers.hal.teleop.declare import ExpertRequest, TakeoverRule, Teleoperator
from openral_data.record.options import rskill_ref
from openral_data.runtime import registry
from openral_data.schemas.rskill import RSkillManifest
from openral_data.schemas.scene import load_recordable_scene

EXPERT = "expert"  # the device's `--teleop` name (producers/hal/teleop/expert.py WHAT)


def scene_rskill(scene: str) -> str:
    """The scene's default rSkill (its expert; the contract its recordings keep)."""
    return rskill_ref(None, load_recordable_scene(registry.resolve_scene_path(scene)))


def expert_request(
    expert: str | None, scene: str | None, rule: TakeoverRule, contract: RSkillManifest, source: str
) -> ExpertRequest:
    """The expert rSkill (`expert`, else `scene`'s default), checked against the driving contract's actions."""
    ref = expert if expert is not None else scene_rskill(scene) if scene is not None else None
    if ref is None:
        raise UsageError("--teleop expert: give a scene (its default rSkill is the expert) or an expert rSkill")
    rskill, path = registry.resolve_rskill(ref)
    mine, theirs = rskill.action_contract, contract.action_contract
    if (mine.dim, list(mine.names), mine.representation) != (theirs.dim, list(theirs.names), theirs.representation):
        raise ConfigError(
            f"{path}: action_contract: the expert acts in {mine.representation} {list(mine.names)}, the policy "
            f"({source}) in {theirs.representation} {list(theirs.names)}"
        )
    make_policy = registry.policy_factory(rskill, str(path))

    def make() -> Teleoperator:
        return make_policy(rskill)

    return ExpertRequest(make, rule, rskill.id)
