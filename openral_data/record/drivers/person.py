"""A person drives through a teleop device (keyboard, gamepad, SpaceMouse: producers/hal/teleop/devices.py)."""

from __future__ import annotations

from contextlib import ExitStack

from openral_data.policies.base import PolicyAdapter
from openral_data.producers.hal.robots.base import HalBase
from openral_data.producers.hal.teleop.declare import Buttons, DeviceRequest, Teleoperator
from openral_data.producers.hal.teleop.keyboard import KeyboardTeleop
from openral_data.record.drivers.base import DriveContext, Driver
from openral_data.record.drivers.choice import DriverChoice, DriverKind
from openral_data.record.drivers.names import teleop_driver


def open_device(driver: Driver, choice: DriverChoice, stack: ExitStack) -> Teleoperator:
    """The person's device, open (and closed with the run): a keyboard is fed the operator's keys (`listener`),
    a device read on its own thread (or the expert, whose rule presses its takeover button) also gives verdicts
    with its buttons (`device`)."""
    assert choice.device is not None  # PERSON, TAKEOVER
    ctx, takeover = driver.ctx, choice.kind is DriverKind.TAKEOVER
    request = DeviceRequest(choice.node, ctx.rskill, ctx.rskill_src, ctx.show, takeover, ctx.teleop_gain, ctx.expert)
    teleop = choice.device.open(request)
    stack.callback(teleop.close)
    if isinstance(teleop, KeyboardTeleop):
        driver.listener = teleop.feed
    if isinstance(teleop, Buttons):
        driver.device = teleop
    return teleop


class PersonDriver(Driver):
    def __init__(self, ctx: DriveContext, choice: DriverChoice, stack: ExitStack) -> None:
        super().__init__(ctx)
        assert choice.device is not None
        self.device_name = choice.device.name
        self.teleop = open_device(self, choice, stack)
        self.help = choice.device.keys  # the device's controls, said before episode 0

    def policy(self, hal: HalBase) -> PolicyAdapter:
        return self.teleop

    def name(self, policy: PolicyAdapter) -> str:
        return teleop_driver(getattr(policy, "type_name", self.device_name))


def open_person(choice: DriverChoice, ctx: DriveContext, stack: ExitStack) -> Driver:
    return PersonDriver(ctx, choice, stack)
