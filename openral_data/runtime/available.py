"""Which scenes and rSkills can run in this environment, and why not (`list` marks the others).

A scene type backed by an external simulator needs its package (an extra, or for LIBERO and ManiSkill3 its own
environment); found with `importlib.util.find_spec`, nothing is imported. An rSkill whose policy is neural needs
its checkpoint (`runnable`; `needs_checkpoint` says which policies are, from the policy's name alone).
"""

from __future__ import annotations

import importlib.util
from typing import TYPE_CHECKING

from openral_data.errors import ConfigError, OpenralError, install_hint

if TYPE_CHECKING:
    from openral_data.schemas.rskill import RSkillManifest

# scene type -> (module it imports, the extra that provides it, the environment it lives in when not this one)
_NEEDS: dict[str, tuple[str, str, str | None]] = {
    "gym_aloha": ("gym_aloha", "aloha", None),
    "gym_pusht": ("gym_pusht", "pusht", None),
    "robosuite": ("robosuite", "robosuite", None),
    "metaworld": ("metaworld", "metaworld", None),
    "libero": ("libero", "libero", "bash scripts/setup_libero.sh"),
    "maniskill": ("mani_skill", "maniskill", "bash scripts/setup_maniskill.sh"),
}


def _installed(module: str) -> bool:
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):
        return False


def scene_type_problem(scene_type: str) -> str | None:
    """Why a scene of `scene_type` cannot run here (`needs the 'robosuite' extra`), or None."""
    need = _NEEDS.get(scene_type)
    if need is None or _installed(need[0]):
        return None
    _, extra, own = need
    return f"needs the '{extra}' extra" if own is None else f"needs their own environment ({own})"


def check_scene_type(scene_type: str, source: str) -> None:
    """Refuse at once a scene whose simulator is not installed, naming what to install: before the scene is built
    while the policy loads (the build's own import error came only once that load had finished, seconds later)."""
    problem = scene_type_problem(scene_type)
    if problem is None:
        return
    _, extra, own = _NEEDS[scene_type]
    if own is not None:  # LIBERO: its extra lives in an environment of its own (as its scene's own check says)
        raise ConfigError(
            f"{source}: scene.type: {scene_type} needs the '{extra}' extra, in an environment of its own ({own})"
        )
    raise ConfigError(f"{source}: scene.type: {scene_type}: {problem}: {install_hint(extra)}")


def needs_checkpoint(policy: str) -> bool:
    """Whether rSkills of `policy` run a checkpoint (a neural policy); the others always run."""
    return policy == "lerobot"


def runnable(rskill: RSkillManifest) -> bool:
    """False for a neural rSkill whose checkpoint is not there (a lerobot policy without its checkpoint folder)."""
    if not needs_checkpoint(rskill.policy):
        return True
    from openral_data.policies.lerobot_policy import checkpoint_dir

    try:
        checkpoint_dir(rskill)
    except (OpenralError, ImportError):
        return False
    return True


def rskill_problem(rskill: RSkillManifest) -> str | None:
    """Why `rskill` cannot run here (`no checkpoint`), or None."""
    return None if runnable(rskill) else "neural rSkills need their checkpoint (policy_extras.checkpoint)"
