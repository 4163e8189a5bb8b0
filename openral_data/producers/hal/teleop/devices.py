"""`--teleop gamepad[=NODE]` and `--teleop spacemouse[=NODE]`: the device named (or found), opened and read
before episode 0, as a `DeviceTeleop` driving the rSkill's `delta_eef_gripper` action (or, with `takeover`, the
teleoperator of an intervention session: policies/intervention.py)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from openral_data.producers.hal.teleop import gamepad, spacemouse
from openral_data.producers.hal.teleop.eef_device import DeviceTeleop
from openral_data.producers.hal.teleop.keyboard import eef_limits
from openral_data.schemas.rskill import RSkillManifest

DEVICE_KINDS = ("gamepad", "spacemouse")
TAKEOVER_TELEOPS = ("keyboard", *DEVICE_KINDS)  # what a person takes over from a policy with (interventions)
TAKEOVER_CONTROLS = {"gamepad": gamepad.TAKEOVER_CONTROL, "spacemouse": spacemouse.TAKEOVER_CONTROL}


def device_kind(spec: str) -> str:
    """`gamepad=/dev/input/event3` -> `gamepad` (the part before `=`)."""
    return spec.partition("=")[0]


def open_teleop_device(
    spec: str,
    rskill: RSkillManifest,
    source: str,
    show: Callable[[str], None] | None = None,
    takeover: bool = False,
) -> DeviceTeleop:
    """The contract is checked first (a wrong rSkill is a config error, whatever is plugged in), then the device
    is opened: a missing one is one line (`hal.teleop`) before anything is recorded. `takeover`: an intervention
    session (a SpaceMouse's right button then takes over instead of marking success)."""
    kind, _, path = spec.partition("=")
    limits = eef_limits(rskill, source, kind)
    node = Path(path) if path else None
    if kind == "gamepad":
        gains, reader = gamepad.GAINS, gamepad.open_gamepad(node, gamepad.GAINS)
    else:
        gains, reader = spacemouse.GAINS, spacemouse.open_spacemouse(node, spacemouse.GAINS, takeover)
    return DeviceTeleop(reader, limits, gains, show)
