"""What a teleop device declares once, in its own module (`DEVICE = TeleopDevice(...)`): its `--teleop` name, how
it is opened for an rSkill's contract, what takes over from a policy with it, and whether it takes a node
(`NAME=NODE`) or reads the operator's terminal. The registry (devices.py) lists the declarations."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from openral_data.producers.hal.session.operator import Command
from openral_data.schemas.rskill import RSkillManifest
from openral_data.types import Observation


class Teleoperator(Protocol):
    """A person's device as the loop drives with it (the policy protocol: reset / step / close)."""

    def reset(self, seed: int) -> None: ...

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]: ...

    def close(self) -> None: ...


@runtime_checkable
class Buttons(Protocol):
    """A teleoperator with buttons the loop reads at the start of every tick (`DeviceOperator.poll`): one that
    ends the episode (`command`), and the takeover button, which calls `on_takeover` (an intervention's switch,
    `policies.intervention.device_switch`). A gamepad's and a SpaceMouse's are pressed by a person, the expert's
    (expert.py) by its takeover rule."""

    on_takeover: Callable[[], None] | None

    def command(self) -> Command | None: ...


@dataclass(frozen=True)
class TakeoverRule:
    """When the expert teleoperator (`--teleop expert`, expert.py) presses its takeover button: the policy's
    proposal departs from the expert's own action by more than `threshold` (in any dimension, as a share of the
    contract's range `high - low`; the raw difference where the contract has no bounds) on `patience` ticks in a
    row; it hands back after driving `hold` ticks."""

    threshold: float = 0.25
    patience: int = 3
    hold: int = 20


@dataclass(frozen=True)
class ExpertRequest:
    """The expert behind `--teleop expert`: its policy (an rSkill's, made by the recording, which resolves it)
    and its takeover rule."""

    make: Callable[[], Teleoperator]
    rule: TakeoverRule = TakeoverRule()
    name: str = "expert"  # the expert rSkill's id (the status lines)


@dataclass(frozen=True)
class DeviceRequest:
    """What a device is opened with: its node (`NAME=NODE`; None: found, or none needed), the rSkill whose
    action contract it keeps, where the contract came from, the status-line writer, and whether a policy drives
    and the person takes over (an intervention session)."""

    node: Path | None
    rskill: RSkillManifest
    source: str
    show: Callable[[str], None] | None = None
    takeover: bool = False
    gain: float = 1.0  # `record --teleop-gain`: the device's motion per press / deflection, scaled
    expert: ExpertRequest | None = None  # `--teleop expert`: the scripted expert and its takeover rule


@dataclass(frozen=True)
class TeleopDevice:
    name: str  # `--teleop NAME` (and `teleop:NAME`, who drove, in the episode's record)
    open: Callable[[DeviceRequest], Teleoperator]  # checks the contract first, then opens the device
    takeover_control: str  # the key or button that takes over from a policy and hands back
    takes_node: bool = False  # `NAME=NODE` names the device's node (else the first one found)
    terminal: bool = False  # fed by the operator's terminal: the operator keys come from the same terminal
    keys: str | None = None  # its controls, said at the prompt before episode 0 (and in docs/hal.md)
