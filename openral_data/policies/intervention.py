"""Interventions (human-in-the-loop, DAgger-style): a policy drives, a person takes over and hands back.

`Intervention` wraps any policy (a `PolicyAdapter`: an rSkill's, a lerobot checkpoint's) and a teleoperator
that is itself a policy (producers/hal/teleop/keyboard.py's `KeyboardTeleop`, producers/hal/teleop/eef_device.py's
`DeviceTeleop`). `TakeoverSwitch` says who drives; its `control` toggles it:
* the keyboard: the switch sits between the operator's terminal reader and the teleoperator: the takeover key
  (`t`) toggles, the other keys go to the teleoperator (only while it drives or is about to: keys typed while
  the policy drives are dropped, so they cannot pile up and fire at the takeover);
* a gamepad or SpaceMouse (`device_switch`): its takeover button (gamepad: RB, the right shoulder; SpaceMouse:
  the right button) toggles; the device's buttons are read by `DeviceOperator.poll` at the start of every tick,
  so the switch sees a press as the keyboard's does. While the person drives, the device's axes drive exactly
  as in plain device teleoperation; gripper presses made while the policy drives are overridden at the takeover.

Every tick the policy is stepped on the observation, also while the person drives, so every frame has the
policy's proposal (`openral.policy_action`, the action's shape and names) next to what was executed (`action`)
and who drove (`openral.intervention`). A press is read by the operator at the start of a tick, so it takes
effect at the first frame whose tick starts after it arrived: at most one tick later. At the takeover the
teleoperator starts from the action in effect (`take_over`: a keyboard drops the moves not yet made and keeps
the gripper where the policy had it, a device keeps the gripper), so the arm does not jump: the end effector
moves from where it is.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from openral_data.columns import INTERVENTION, POLICY_ACTION
from openral_data.policies.base import PolicyAdapter
from openral_data.producers.hal.teleop.declare import Buttons
from openral_data.producers.hal.teleop.keys import TAKEOVER_KEY
from openral_data.types import FrameColumn, Observation


def takeover_help(control: str) -> str:
    """The line said once before episode 0: what takes over and hands back."""
    return f"takeover: {control} hands control to you and back"


def intervention_columns(action_names: Sequence[str]) -> tuple[FrameColumn, ...]:
    """The per-frame columns of an intervention session: the policy's proposal and the flag."""
    return (FrameColumn(POLICY_ACTION, "float32", tuple(action_names)), FrameColumn(INTERVENTION, "bool"))


@runtime_checkable
class TakesOver(Protocol):
    """A teleoperator that can start from the action in effect (no jump at the takeover)."""

    def take_over(self, action: npt.NDArray[np.float32]) -> None: ...


@runtime_checkable
class Watches(Protocol):
    """A teleoperator that watches the policy drive: every tick, before anyone drives, it sees the observation and
    the policy's proposal (the expert teleoperator, producers/hal/teleop/expert.py, decides there whether to press
    its takeover button; a person watches the scene instead)."""

    def watch(self, observation: Observation, instruction: str, proposal: npt.NDArray[np.float32]) -> None: ...


class TakeoverSwitch:
    """Who is asked to drive. The keyboard side: `feed` gets every key the operator does not use; `t` toggles the
    request. `toggle` (a device's takeover button, `device_switch`) does the same. A takeover starts the
    teleoperator from the action in effect at once (`on_takeover`), so the keys typed or buttons pressed after it
    (before the next tick) count. `control` names what toggles it (the status lines and the help say it)."""

    def __init__(self, teleop_feed: Callable[[str], None] | None = None, control: str = TAKEOVER_KEY) -> None:
        self.teleop_feed = teleop_feed
        self.control = control
        self.requested = False  # the person asked to drive
        self.on_takeover: Callable[[], None] | None = None  # set by the `Intervention` the switch drives

    def feed(self, ch: str) -> None:
        if ch.lower() == TAKEOVER_KEY:
            self.toggle()
        elif self.requested and self.teleop_feed is not None:
            self.teleop_feed(ch)

    def toggle(self) -> None:
        self.requested = not self.requested
        if self.requested and self.on_takeover is not None:
            self.on_takeover()

    def reset(self) -> None:
        self.requested = False


def device_switch(device: Buttons, control: str) -> TakeoverSwitch:
    """The switch a device's takeover button (`control`, e.g. `RB`) toggles (`DeviceTeleop.on_takeover`)."""
    switch = TakeoverSwitch(control=control)
    device.on_takeover = switch.toggle
    return switch


class Intervention:
    """`policy` drives until the switch hands control to `teleop` and back; both are stepped as the loop's
    one policy. After each `step`, `columns()` holds the frame's proposal and flag."""

    def __init__(
        self,
        policy: PolicyAdapter,
        teleop: PolicyAdapter,
        switch: TakeoverSwitch,
        show: Callable[[str], None] | None = None,
        status_every: int = 4,
    ) -> None:
        self.policy = policy
        self.teleop = teleop
        self.switch = switch
        self.show = show
        self.status_every = status_every
        self.intervening = False
        self.frame = 0
        self.proposal: npt.NDArray[np.float32] | None = None
        self.executed: npt.NDArray[np.float32] | None = None  # the action in effect (the last one returned)
        switch.on_takeover = self._take_over

    def reset(self, seed: int) -> None:
        self.policy.reset(seed)
        self.teleop.reset(seed)
        self.switch.reset()
        self.intervening = False
        self.frame = 0
        self.proposal = self.executed = None

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        proposal = self.policy.step(observation, instruction)  # the bridge checks it (`columns`), as the action
        if isinstance(self.teleop, Watches):
            self.teleop.watch(observation, instruction, proposal)
        if self.switch.requested != self.intervening:
            self.intervening = self.switch.requested
            if self.intervening and self.executed is None:  # taken over before the first frame
                self._take_over(proposal)
            c = self.switch.control
            self._say(
                f"teleop drives ({c} hands back)" if self.intervening else f"policy drives again ({c} takes over)"
            )
        elif not self.intervening and self.status_every and self.frame % self.status_every == 0:
            self._say(f"policy drives ({self.switch.control} takes over)")
        action = self.teleop.step(observation, instruction) if self.intervening else proposal
        self.proposal, self.executed = proposal, action
        self.frame += 1
        return self.executed

    def _take_over(self, in_effect: npt.NDArray[np.float32] | None = None) -> None:
        action = in_effect if in_effect is not None else self.executed
        if action is not None and isinstance(self.teleop, TakesOver):
            self.teleop.take_over(action)

    def _say(self, what: str) -> None:
        if self.show is not None:
            self.show(f"frame {self.frame}: {what}")

    def columns(self) -> dict[str, Any]:
        """The last step's frame columns (`intervention_columns`)."""
        if self.proposal is None:
            raise RuntimeError("Intervention.columns() before step()")
        return {POLICY_ACTION: self.proposal, INTERVENTION: self.intervening}

    def close(self) -> None:
        try:
            self.policy.close()
        finally:
            self.teleop.close()
