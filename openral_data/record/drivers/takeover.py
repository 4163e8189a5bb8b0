"""An rSkill's policy (or a checkpoint's: the DAgger round) drives and a person takes over and hands back
(interventions: policies/intervention.py): the keyboard's `t`, a device's takeover button, or the expert's rule
(`--teleop expert`)."""

from __future__ import annotations

from contextlib import ExitStack

from openral_data.policies.base import PolicyAdapter
from openral_data.policies.intervention import Intervention, TakeoverSwitch, device_switch, takeover_help
from openral_data.producers.hal.robots.base import HalBase
from openral_data.record.drivers.base import DriveContext, Driver, policy_name
from openral_data.record.drivers.checkpoint import check_checkpoint
from openral_data.record.drivers.choice import DriverChoice
from openral_data.record.drivers.names import teleop_driver
from openral_data.record.drivers.person import open_device


class TakeoverDriver(Driver):
    takeover = True

    def __init__(self, ctx: DriveContext, choice: DriverChoice, stack: ExitStack) -> None:
        super().__init__(ctx)
        assert choice.device is not None
        self.device_name = choice.device.name
        self.teleop = open_device(self, choice, stack)
        control = choice.device.takeover_control
        if self.device is not None:  # the device's takeover button toggles the switch
            self.switch = device_switch(self.device, control)
        else:  # the takeover key goes to the switch, the other keys through it to the teleoperator
            self.switch = TakeoverSwitch(self.listener, control)
            self.listener = self.switch.feed
        self.help = " · ".join(filter(None, (takeover_help(control), choice.device.keys)))

    def policy(self, hal: HalBase) -> PolicyAdapter:
        if self.ctx.checkpoint is not None:
            check_checkpoint(self.ctx, hal)
        return Intervention(self.ctx.make_policy(self.ctx.rskill), self.teleop, self.switch, show=self.ctx.show)

    def name(self, policy: PolicyAdapter) -> str:
        """Both: `policy:<id>+teleop:<device>`."""
        return f"{policy_name(policy, self.ctx.rskill)}+{teleop_driver(self.device_name)}"


def open_takeover(choice: DriverChoice, ctx: DriveContext, stack: ExitStack) -> Driver:
    return TakeoverDriver(ctx, choice, stack)
