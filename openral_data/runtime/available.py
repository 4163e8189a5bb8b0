"""Which scenes and rSkills can run in this environment, and why not (`list` marks the others).

A scene type backed by an external simulator needs its package (an extra, or for LIBERO its own environment);
found with `importlib.util.find_spec`, nothing is imported. An rSkill whose policy is neural needs its checkpoint
(`runtime.compat.runnable`).
"""

from __future__ import annotations

import importlib.util

from openral_data.errors import ConfigError, install_hint
from openral_data.runtime.compat import runnable
from openral_data.schemas.rskill import RSkillManifest

# scene type -> (module it imports, how to get it)
_NEEDS = {
    "gym_aloha": ("gym_aloha", "the 'aloha' extra"),
    "gym_pusht": ("gym_pusht", "the 'pusht' extra"),
    "robosuite": ("robosuite", "the 'robosuite' extra"),
    "metaworld": ("metaworld", "the 'metaworld' extra"),
    "libero": ("libero", "their own environment (bash scripts/setup_libero.sh)"),
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
    return f"needs {need[1]}"


def check_scene_type(scene_type: str, source: str) -> None:
    """Refuse at once a scene whose simulator is not installed, naming what to install: before the scene is built
    while the policy loads (the build's own import error came only once that load had finished, seconds later)."""
    problem = scene_type_problem(scene_type)
    if problem is None:
        return
    need = _NEEDS[scene_type][1]
    extra = need.removeprefix("the '").removesuffix("' extra")
    if extra == need:  # LIBERO: its extra lives in an environment of its own (as its scene's own check says)
        raise ConfigError(
            f"{source}: scene.type: {scene_type} needs the '{scene_type}' extra, in an environment of its own "
            "(bash scripts/setup_libero.sh)"
        )
    raise ConfigError(f"{source}: scene.type: {scene_type}: {problem}: {install_hint(extra)}")


def rskill_problem(rskill: RSkillManifest) -> str | None:
    """Why `rskill` cannot run here (`no checkpoint`), or None."""
    return None if runnable(rskill) else "neural rSkills need their checkpoint (policy_extras.checkpoint)"
