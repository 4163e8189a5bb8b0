"""What a simulated scene promises: its ProducerSpec (every simulated scene can restore a recorded initial state),
and the rSkill contract checks it makes: is the skill's state/action representation one the scene
produces/accepts? One refusal shape, `<rskill>: <side>_contract.representation: <why>`, for all of them."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Literal

from openral_data.errors import CompatibilityError
from openral_data.schemas.rskill import RSkillManifest
from openral_data.schemas.scene import SceneCamera
from openral_data.types import CameraShape, ProducerSpec

Side = Literal["state", "action"]


def scene_spec(state_dim: int | None, action_dim: int | None, cameras: Iterable[SceneCamera], fps: int) -> ProducerSpec:
    """The spec of a simulated scene rendering `cameras` at their YAML sizes; `None` dims mean "any"."""
    return ProducerSpec(
        state_dim=state_dim,
        action_dim=action_dim,
        cameras={c.name: CameraShape(c.height, c.width) for c in cameras},
        fps=fps,
        can_restore_state=True,
    )


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
