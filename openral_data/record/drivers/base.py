"""What every driver kind gives the fixed-rate loop (`Driver`), and what it is opened with (`DriveContext`).

A driver is opened inside the run's `ExitStack` and registers the closing of whatever it opens there (a device,
a leader arm), so nothing it opened outlives the run, whatever fails after it."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass

from openral_data.policies.base import PolicyAdapter
from openral_data.policies.checkpoint import OperatedPolicy, PolicyCheckpoint
from openral_data.producers.hal.robots.base import HalBase
from openral_data.producers.hal.teleop.declare import Buttons, ExpertRequest
from openral_data.record.drivers.names import rskill_driver
from openral_data.runtime.registry import PolicyFactory
from openral_data.schemas.robot import RobotManifest
from openral_data.schemas.rskill import RSkillManifest


@dataclass(frozen=True)
class DriveContext:
    robot: RobotManifest
    rskill: RSkillManifest  # the contract the driver's actions keep
    rskill_src: str
    make_policy: PolicyFactory  # the rSkill's (or the checkpoint's) policy, loaded when the HAL is built
    fps: int
    show: Callable[[str], None] | None = None  # the person's status lines (None: the run is quiet)
    checkpoint: PolicyCheckpoint | None = None  # `--policy`: checked against the HAL before it loads
    teleop_gain: float = 1.0  # `--teleop-gain`: a person's device moves this many times its default step
    expert: ExpertRequest | None = None  # `--teleop expert`: the scripted expert and its takeover rule


class Driver(ABC):
    listener: Callable[[str], None] | None = None  # the keys a keyboard operator passes on (keys, `t`)
    device: Buttons | None = None  # a device with buttons: they give the operator's verdicts (and the takeover)
    help: str | None = None  # said once with the operator's keys: the device's controls, how a person takes over
    takeover: bool = False  # the frames carry the intervention columns (policies/intervention.py)

    def __init__(self, ctx: DriveContext) -> None:
        self.ctx = ctx

    @abstractmethod
    def policy(self, hal: HalBase) -> PolicyAdapter:
        """What the loop asks for an action every tick, once the HAL is built (not yet connected)."""

    @abstractmethod
    def name(self, policy: PolicyAdapter) -> str:
        """Who drove, as the episode's record says (`operator`: record/drivers/names.py)."""


def policy_name(policy: PolicyAdapter, rskill: RSkillManifest) -> str:
    """`policy:<id>` or `script:<id>`; a checkpoint's policy names itself."""
    return policy.operator if isinstance(policy, OperatedPolicy) else rskill_driver(rskill)
