"""`metaworld-expert`: MetaWorld's own scripted expert for whatever task the scene runs (one rSkill, 50 tasks).

MetaWorld ships one hand-written policy per v3 task (`metaworld.policies.Sawyer<Task>V3Policy`); they read the
full 39-entry observation (hand, gripper, object poses, goal), which the MetaWorld scene passes as privileged
ground truth. The policy for the task is picked on the first observation of each episode, so the same rSkill
records expert datasets for any task. Actions are MetaWorld's [dx, dy, dz, grab] clipped to [-1, 1].
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
import numpy.typing as npt

from openral_data.errors import ConfigError
from openral_data.schemas.rskill import RSkillManifest
from openral_data.types import Observation

_POLICY_NAME_EXCEPTIONS = {"peg-insert-side-v3": "SawyerPegInsertionSideV3Policy"}


def policy_class_name(task: str) -> str:
    """`pick-place-v3` -> `SawyerPickPlaceV3Policy` (MetaWorld's naming, one exception)."""
    if task in _POLICY_NAME_EXCEPTIONS:
        return _POLICY_NAME_EXCEPTIONS[task]
    base = task.removesuffix("-v3")
    return "Sawyer" + "".join(w.capitalize() for w in base.split("-")) + "V3Policy"


def expert_for(task: str) -> Any:
    from openral_data.producers.sim.metaworld import import_metaworld

    import_metaworld()
    from metaworld import policies

    cls = getattr(policies, policy_class_name(task), None)
    if cls is None:
        raise ConfigError(f"metaworld-expert: MetaWorld has no scripted policy for task {task!r}")
    return cls()


class MetaWorldExpert:
    def __init__(self, rskill: RSkillManifest) -> None:
        if rskill.action_contract.dim != 4 or rskill.state_contract.dim != 4:
            raise ConfigError(
                f"rskill {rskill.id}: state_contract/action_contract: MetaWorld experts speak dim 4 / dim 4"
            )
        self._task: str | None = None
        self._policy: Any = None

    def reset(self, seed: int) -> None:
        pass

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        p = observation.privileged
        if p.get("suite") != "metaworld":
            raise ConfigError("metaworld-expert needs a MetaWorld scene (no MetaWorld observation in the producer)")
        task = str(p["task"])
        if task != self._task:
            self._task, self._policy = task, expert_for(task)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "Constant(s) may be too high": MetaWorld clips, and so do we
            action = self._policy.get_action(np.asarray(p["metaworld_obs"], dtype=np.float64))
        return np.clip(np.asarray(action, dtype=np.float32), -1.0, 1.0)

    def close(self) -> None:
        pass
