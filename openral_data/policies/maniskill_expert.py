"""`maniskill-expert`: ManiSkill3's own motion-planning solutions (mani_skill.examples.motionplanning, mplib 0.1.1)
as a scripted expert for whatever ManiSkill task the scene runs.

A solution drives an environment itself (it resets it with a seed, plans with mplib from the simulator's ground
truth and steps it). The expert runs it in an environment of its own, built like the scene's (same task, CPU
backend, pd_joint_pos) but without cameras, reset with the episode's seed (`privileged["maniskill_seed"]`), and
keeps the actions it steps; the scene then receives them one per step. The CPU backend is deterministic, so the
scene follows the planned rollout exactly (the expert's success is ManiSkill's `success` signal in the scene,
not the plan's claim). After the plan, the last action holds the pose.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from openral_data.errors import ConfigError
from openral_data.producers.sim.maniskill.scene import ACTION_DIM, KIND, STATE_DIM, make_env
from openral_data.producers.sim.maniskill.tasks import BY_ID
from openral_data.schemas.rskill import RSkillManifest
from openral_data.types import Observation


class _Recorder:
    """The environment a solution drives, keeping every action it steps."""

    def __init__(self, env: Any) -> None:
        self._env = env
        self.actions: list[npt.NDArray[np.float32]] = []

    def __getattr__(self, name: str) -> Any:
        return getattr(self._env, name)

    def step(self, action: Any) -> Any:
        self.actions.append(np.asarray(action, dtype=np.float32).reshape(-1).copy())
        return self._env.step(action)


def plan(env_id: str, seed: int) -> list[npt.NDArray[np.float32]]:
    """The actions ManiSkill's solution for `env_id` steps from `reset(seed=seed)`."""
    task = BY_ID.get(env_id)
    if task is None or task.expert is None:
        raise ConfigError(f"maniskill-expert: ManiSkill has no motion-planning solution for {env_id!r}")
    from mani_skill.examples.motionplanning.panda import solutions

    solve = getattr(solutions, task.expert)
    env = make_env(env_id, "maniskill-expert", obs_mode="none")
    try:
        recorder = _Recorder(env)
        solve(recorder, seed=seed, debug=False, vis=False)
        return recorder.actions
    finally:
        env.close()


class ManiSkillExpert:
    def __init__(self, rskill: RSkillManifest) -> None:
        if rskill.action_contract.dim != ACTION_DIM or rskill.state_contract.dim != STATE_DIM:
            raise ConfigError(
                f"rskill {rskill.id}: state_contract/action_contract: ManiSkill experts speak dim "
                f"{STATE_DIM} / dim {ACTION_DIM}"
            )
        self._planned_for: tuple[str, int] | None = None
        self._actions: list[npt.NDArray[np.float32]] = []
        self._t = 0

    def reset(self, seed: int) -> None:
        self._planned_for = None

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        p = observation.privileged
        if p.get("suite") != KIND or "maniskill_seed" not in p:
            raise ConfigError("maniskill-expert needs a ManiSkill scene (no ManiSkill observation in the producer)")
        key = (str(p["task"]), int(p["maniskill_seed"]))
        if key != self._planned_for:
            self._actions = plan(*key)
            self._planned_for, self._t = key, 0
        if not self._actions:
            raise ConfigError(f"maniskill-expert: the solution for {key[0]} (seed {key[1]}) stepped no action")
        action = self._actions[min(self._t, len(self._actions) - 1)]
        self._t += 1
        return action.copy()

    def close(self) -> None:
        pass
