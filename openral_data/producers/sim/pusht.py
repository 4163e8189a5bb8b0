"""`gym_pusht`: gym-pusht 0.1.8's PushT (pymunk, 2-D) as a SimRollout.

The agent is a disc; the action is its target position [x, y] in pixels (0..512), reached by gym-pusht's PD
control (10 control steps per second). State is the agent position [x, y] (what lerobot's pusht datasets
store). The one camera is gym-pusht's own top-down view at the YAML's resolution (its observation image, no
action marker). Success is gym-pusht's: the T covers ≥ 95 % of the goal (`info["is_success"]`); the reward is
its clipped coverage. Ground truth (block pose, coverage) is `Observation.privileged`, never recorded.

Restore: gym-pusht's `reset_to_state` option does not set the state it is given (documented legacy quirk), but
its seeded reset is exact, so `reset_to` re-runs the seeded reset and checks the result against the recorded
state; the same actions then reproduce the rollout bit for bit (tested).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
from pydantic import Field

from openral_data.errors import CompatibilityError, ConfigError
from openral_data.producers.sim.contract import scene_spec
from openral_data.producers.sim.external import check_fps, named_cameras, require
from openral_data.producers.sim.initial_state import check_envelope
from openral_data.producers.sim.params import parse_params
from openral_data.schemas.base import StrictModel
from openral_data.schemas.rskill import RSkillManifest
from openral_data.schemas.scene import SimScene
from openral_data.types import Observation, Privileged, StepResult

KIND = "gym_pusht"
STATE_FORMAT = 1
FPS = 10  # gym-pusht's control rate (metadata render_fps): 10 physics steps of 10 ms per action
CAMERAS = ("top",)


class PushTParams(StrictModel):
    block_cog: tuple[float, float] | None = Field(default=None, description="gym-pusht block_cog")
    damping: float | None = Field(default=None, ge=0, description="gym-pusht damping")


class PushTScene:
    def __init__(self, scene: SimScene, rskill: RSkillManifest, source: str = "scene", rskill_source: str = "rskill"):
        params = parse_params(PushTParams, scene, source)
        check_fps(scene, FPS, source)
        cams = named_cameras(scene, CAMERAS, source, max_count=1)
        if rskill.action_contract.dim != 2 or rskill.state_contract.dim != 2:
            raise CompatibilityError(
                f"{rskill_source}: action_contract.dim/state_contract.dim: PushT takes a 2-D target position and "
                f"produces the 2-D agent position, got {rskill.action_contract.dim}/{rskill.state_contract.dim}"
            )
        envs = require("gym_pusht.envs", "pusht", source)
        self._camera = cams[0] if cams else None
        width, height = (self._camera.width, self._camera.height) if self._camera else (96, 96)
        self.env: Any = envs.PushTEnv(
            obs_type="pixels_agent_pos" if self._camera else "environment_state_agent_pos",
            render_mode="rgb_array",
            block_cog=params.block_cog,
            damping=params.damping,
            observation_width=width,
            observation_height=height,
        )
        self.spec = scene_spec(2, 2, cams, FPS, source=source)
        self._task = scene.task.instruction
        self._seed = 0
        self._t = 0
        self._initial: dict[str, Any] = {}
        self._last_obs: Any = None
        self._coverage = 0.0

    # -- SimRollout ------------------------------------------------------------------------------------------
    def reset(self, seed: int) -> Observation:
        self._seed = seed
        self._last_obs, _ = self.env.reset(seed=seed)
        self._t = 0
        self._coverage = float(self.env._get_coverage())
        self._initial = {"format": STATE_FORMAT, "kind": KIND, "seed": seed, "state": self._sim_state()}
        return self._observation()

    def reset_to(self, initial_state: dict[str, Any]) -> Observation:
        check_envelope(initial_state, STATE_FORMAT, KIND)
        try:
            seed, recorded = int(initial_state["seed"]), [float(v) for v in initial_state["state"]]
        except (KeyError, TypeError, ValueError) as exc:
            raise ConfigError(f"initial_state: does not fit gym-pusht: {exc}") from None
        obs = self.reset(seed)
        if self._sim_state() != recorded:
            raise ConfigError(
                f"initial_state: state: the seeded reset gives {self._sim_state()}, the recording has {recorded} "
                "(another gym-pusht or pymunk version?)"
            )
        return obs

    def step(self, action: npt.NDArray[np.float32]) -> StepResult:
        self._last_obs, reward, terminated, _, info = self.env.step(np.asarray(action, dtype=np.float64))
        self._t += 1
        self._coverage = float(info["coverage"])
        success = bool(info["is_success"])
        return StepResult(self._observation(), reward=float(reward), success=success, terminated=bool(terminated))

    def render(self) -> dict[str, npt.NDArray[np.uint8]]:
        if self._camera is None:
            return {}
        return {self._camera.name: np.ascontiguousarray(self._last_obs["pixels"], dtype=np.uint8).copy()}

    def initial_state(self) -> dict[str, Any]:
        return dict(self._initial)

    def close(self) -> None:
        self.env.close()

    # -- helpers ---------------------------------------------------------------------------------------------
    def _sim_state(self) -> list[float]:
        e = self.env
        return [float(e.agent.position[0]), float(e.agent.position[1]), float(e.block.position[0]),
                float(e.block.position[1]), float(e.block.angle)]  # fmt: skip

    def _observation(self) -> Observation:
        s = self._sim_state()
        privileged: Privileged = {
            "agent_pos": np.array(s[:2]),
            "block_pos": np.array(s[2:4]),
            "block_angle": s[4],
            "goal_pose": np.asarray(self.env.goal_pose, dtype=np.float64),
            "coverage": self._coverage,
        }
        return Observation(
            images=self.render(),
            state=np.asarray(self._last_obs["agent_pos"], dtype=np.float32).copy(),
            task=self._task,
            time=self._t / FPS,
            privileged=privileged,
        )
