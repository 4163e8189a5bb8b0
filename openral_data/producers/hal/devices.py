"""`--teleop gamepad[=NODE]` and `--teleop spacemouse[=NODE]`: the device named (or found), opened and read
before episode 0, as a `DeviceTeleop` driving the rSkill's `delta_eef_gripper` action."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from openral_data.producers.hal.eef_device import DeviceTeleop
from openral_data.producers.hal.gamepad import GAINS as GAMEPAD_GAINS
from openral_data.producers.hal.gamepad import open_gamepad
from openral_data.producers.hal.spacemouse import GAINS as SPACEMOUSE_GAINS
from openral_data.producers.hal.spacemouse import open_spacemouse
from openral_data.producers.hal.teleop import eef_limits
from openral_data.schemas.rskill import RSkillManifest

DEVICE_KINDS = ("gamepad", "spacemouse")


def device_kind(spec: str) -> str:
    """`gamepad=/dev/input/event3` -> `gamepad` (the part before `=`)."""
    return spec.partition("=")[0]


def open_teleop_device(
    spec: str, rskill: RSkillManifest, source: str, show: Callable[[str], None] | None = None
) -> DeviceTeleop:
    """The contract is checked first (a wrong rSkill is a config error, whatever is plugged in), then the device
    is opened: a missing one is one line (`hal.teleop`) before anything is recorded."""
    kind, _, path = spec.partition("=")
    limits = eef_limits(rskill, source, kind)
    node = Path(path) if path else None
    if kind == "gamepad":
        gains, reader = GAMEPAD_GAINS, open_gamepad(node, GAMEPAD_GAINS)
    else:
        gains, reader = SPACEMOUSE_GAINS, open_spacemouse(node, SPACEMOUSE_GAINS)
    return DeviceTeleop(reader, limits, gains, show)
