"""The rSkill contract checks every simulated scene makes: is the skill's state/action representation one the
scene produces/accepts? One refusal shape, `<rskill>: <side>_contract.representation: <why>`, for all of them."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

from openral_data.errors import CompatibilityError
from openral_data.schemas.rskill import RSkillManifest

Side = Literal["state", "action"]


def check_representation(rskill_source: str, side: Side, representation: str, valid: Sequence[str], why: str) -> None:
    """CompatibilityError `why` (the scene's own words) unless `representation` is one of `valid`."""
    if representation not in valid:
        raise CompatibilityError(f"{rskill_source}: {side}_contract.representation: {why}")


def check_representations(
    rskill: RSkillManifest,
    rskill_source: str,
    scene_label: str,
    produced: Sequence[str],
    accepted: Sequence[str],
    accepted_note: str = "",
) -> None:
    """The skill's state representation must be one the scene produces, its action one the scene accepts
    (`accepted_note` follows the accepted list in the message, e.g. what those actions mean)."""
    state = rskill.state_contract.representation
    action = rskill.action_contract.representation
    check_representation(
        rskill_source,
        "state",
        state,
        produced,
        f"{state!r} is not produced by {scene_label} (they produce {', '.join(produced)})",
    )
    check_representation(
        rskill_source,
        "action",
        action,
        accepted,
        f"{action!r} is not accepted by {scene_label} (they accept {', '.join(accepted)}{accepted_note})",
    )
