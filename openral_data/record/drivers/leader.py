"""A person drives through the robot's leader arm (its manifest's `hardware.teleop`, a lerobot teleoperator)."""

from __future__ import annotations

from contextlib import ExitStack

from openral_data import manifests
from openral_data.policies.base import PolicyAdapter
from openral_data.producers.hal.robots.base import HalBase
from openral_data.producers.hal.teleop.leader import LeaderTeleop
from openral_data.record.drivers.base import DriveContext, Driver
from openral_data.record.drivers.choice import DriverChoice
from openral_data.record.drivers.names import teleop_driver


class LeaderDriver(Driver):
    def __init__(self, ctx: DriveContext, stack: ExitStack) -> None:
        super().__init__(ctx)
        self.leader = LeaderTeleop(ctx.robot, str(manifests.robot_file(ctx.robot.name)))
        stack.callback(self.leader.close)

    def policy(self, hal: HalBase) -> PolicyAdapter:
        return self.leader

    def name(self, policy: PolicyAdapter) -> str:
        return teleop_driver(self.leader.type_name)  # its lerobot type, e.g. so101_leader


def open_leader(choice: DriverChoice, ctx: DriveContext, stack: ExitStack) -> Driver:
    return LeaderDriver(ctx, stack)
