"""A lerobot checkpoint drives (`--policy`): checked against the built HAL before it loads."""

from __future__ import annotations

from contextlib import ExitStack

from openral_data import manifests
from openral_data.policies.base import PolicyAdapter
from openral_data.policies.checkpoint import check_fits
from openral_data.producers.hal.robots.base import HalBase
from openral_data.record.drivers.base import DriveContext, Driver
from openral_data.record.drivers.choice import DriverChoice
from openral_data.record.drivers.rskill import RSkillDriver


def check_checkpoint(ctx: DriveContext, hal: HalBase) -> None:
    """The checkpoint's contract against what the (built, not yet connected) HAL gives and takes at `--fps`: its
    state, actions, cameras and environment state (a scene's object poses; none on hardware)."""
    assert ctx.checkpoint is not None  # `--policy` resolved it
    where = f"robot {manifests.robot_file(ctx.robot.name)}"
    cameras = {n: c.shape for n, c in hal.cameras.items()}
    check_fits(
        ctx.checkpoint, where, state_dim=hal.state_dim, action_dim=hal.action_dim, cameras=cameras, fps=ctx.fps,
        environment_dim=len(hal.environment_state_names),
    )  # fmt: skip


class CheckpointDriver(RSkillDriver):
    def policy(self, hal: HalBase) -> PolicyAdapter:
        """The checkpoint checked against the HAL (`check_checkpoint`), then the policy."""
        check_checkpoint(self.ctx, hal)
        return super().policy(hal)


def open_checkpoint_driver(choice: DriverChoice, ctx: DriveContext, stack: ExitStack) -> Driver:
    return CheckpointDriver(ctx)
