"""The scripted expert as a teleop device (`--teleop expert`): the DAgger round's "person".

A policy drives an intervention session (`record --scene S --policy CHECKPOINT --teleop expert`, or `--rskill
R`); the expert is the scene's scripted expert rSkill (`ExpertRequest.make`, resolved by the recording), stepped
on every tick's observation beside the policy (`watch`, called by `policies.intervention.Intervention`). Its
takeover rule (`TakeoverRule`) decides when it presses its takeover button: the button press is queued and read
by the loop at the start of the next tick (`command`, through `DeviceOperator.poll`), exactly as a gamepad's RB
press is, so it toggles the same switch (`device_switch`), the frames it drives are marked
`openral.intervention` by the same code and their `action` is the expert's own. It hands back (a second press)
after driving `hold` ticks, and the rule starts counting again.

A press made while frame k is worked on takes effect at frame k+1, as a person's does; the expert's action is
computed once per tick (its policy may keep state: a scripted expert's phase), so while it drives, frame k's
action is the one it computed from frame k's observation. Driving without a policy (`--teleop expert` as the
only driver, no takeover) it is simply the expert rSkill.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from openral_data.errors import UsageError
from openral_data.producers.hal.session.operator import Command
from openral_data.producers.hal.teleop.declare import DeviceRequest, TakeoverRule, TeleopDevice, Teleoperator
from openral_data.types import Observation

WHAT = "expert"
CONTROL = "the expert's takeover rule"


class ExpertTeleop:
    """The expert's actions, and a takeover button its rule presses (`Buttons`)."""

    def __init__(self, expert: Callable[[], Teleoperator], rule: TakeoverRule, span: npt.NDArray[np.float64]) -> None:
        self.expert = expert()
        self.rule = rule
        self.span = span  # per action dimension: what a difference is divided by
        self.type_name = WHAT  # `operator` in the episode's record: ...+teleop:expert
        self.on_takeover: Callable[[], None] | None = None  # the intervention's switch (`device_switch`)
        self._clear()

    def reset(self, seed: int) -> None:
        self.expert.reset(seed)
        self._clear()

    def _clear(self) -> None:
        self.driving = False  # the expert drives (its last press took over)
        self.pressed = False  # a press waits for the next tick's poll
        self.run = 0  # ticks in a row the policy departed from the expert
        self.driven = 0  # ticks the expert has driven since it took over
        self.action: npt.NDArray[np.float32] | None = None  # this tick's, computed by `watch`

    def departure(self, proposal: npt.NDArray[np.float32], action: npt.NDArray[np.float32]) -> float:
        """The largest difference of the two actions, each dimension as a share of its range."""
        return float(np.max(np.abs(np.asarray(proposal, np.float64) - action) / self.span))

    def watch(self, observation: Observation, instruction: str, proposal: npt.NDArray[np.float32]) -> None:
        """Every tick of an intervention session, before anyone drives: the expert's action on this observation,
        compared with the policy's proposal; the rule may press the button (read at the next tick)."""
        self.action = self._expert_step(observation, instruction)
        if self.pressed:
            return
        if self.driving:
            self.driven += 1
            self.pressed = self.driven >= self.rule.hold
            return
        self.run = self.run + 1 if self.departure(proposal, self.action) > self.rule.threshold else 0
        self.pressed = self.run >= self.rule.patience

    def command(self) -> Command | None:
        """The loop's poll at the start of a tick: a pending press toggles who drives (`on_takeover`). The
        expert never ends an episode (the scene's success and the step limit do)."""
        if self.pressed:
            self.pressed = False
            self.driving = not self.driving
            self.run = self.driven = 0
            if self.on_takeover is not None:
                self.on_takeover()
        return None

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        action, self.action = self.action, None
        return action if action is not None else self._expert_step(observation, instruction)

    def _expert_step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        action = self.expert.step(observation, instruction)
        return np.asarray(action, dtype=np.float32)

    def close(self) -> None:
        self.expert.close()


def open_expert(request: DeviceRequest) -> ExpertTeleop:
    """The expert the recording resolved (`request.expert`) with its rule; the contract's range scales the rule's
    threshold."""
    if request.expert is None:
        raise UsageError("--teleop expert: needs a scene (its default rSkill is the expert) or an expert rSkill")
    contract = request.rskill.action_contract
    span: npt.NDArray[np.float64] = np.ones(contract.dim)
    if contract.low is not None and contract.high is not None:
        width = np.asarray(contract.high, np.float64) - np.asarray(contract.low, np.float64)
        span = np.where(np.isfinite(width) & (width > 0), width, 1.0)
    return ExpertTeleop(request.expert.make, request.expert.rule, span)


DEVICE = TeleopDevice(
    WHAT, open_expert, CONTROL, keys="the scene's scripted expert takes over when the policy departs from it"
)
