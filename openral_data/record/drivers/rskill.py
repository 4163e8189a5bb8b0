"""An rSkill drives: its policy, a learned one or a script (`record/drivers/names.py` names which)."""

from __future__ import annotations

from contextlib import ExitStack

from openral_data.policies.base import PolicyAdapter
from openral_data.producers.hal.robots.base import HalBase
from openral_data.record.drivers.base import DriveContext, Driver, policy_name
from openral_data.record.drivers.choice import DriverChoice


class RSkillDriver(Driver):
    def policy(self, hal: HalBase) -> PolicyAdapter:
        return self.ctx.make_policy(self.ctx.rskill)

    def name(self, policy: PolicyAdapter) -> str:
        return policy_name(policy, self.ctx.rskill)


def open_rskill(choice: DriverChoice, ctx: DriveContext, stack: ExitStack) -> Driver:
    return RSkillDriver(ctx)
