"""The teleop devices a person drives with (`--teleop NAME[=NODE]`), each declared in its own module: adding a
device is one module declaring `DEVICE = TeleopDevice(...)` (declare.py) plus its line in `DEVICES`. `expert` is
not a person's: the scene's scripted expert, taking over by a rule (expert.py; the DAgger round). A leader
arm is not one of them: it is the robot manifest's `hardware.teleop` (leader.py, `--teleop leader`)."""

from __future__ import annotations

from pathlib import Path

from openral_data.errors import UsageError
from openral_data.producers.hal.teleop import expert, gamepad, keyboard, spacemouse
from openral_data.producers.hal.teleop.declare import TeleopDevice

DEVICES: dict[str, TeleopDevice] = {
    d.name: d for d in (keyboard.DEVICE, gamepad.DEVICE, spacemouse.DEVICE, expert.DEVICE)
}
LEADER = "leader"  # `--teleop leader`: the manifest's hardware.teleop drives the robot's own joints


def valid_teleops() -> str:
    """`keyboard, expert, leader, gamepad[=NODE], spacemouse[=NODE]`: what `--teleop` takes."""
    plain = [d.name for d in DEVICES.values() if not d.takes_node]
    nodes = [f"{d.name}[=NODE]" for d in DEVICES.values() if d.takes_node]
    return ", ".join([*plain, LEADER, *nodes])


def find_device(spec: str) -> tuple[TeleopDevice, Path | None]:
    """`gamepad=/dev/input/event3` -> the gamepad's declaration and its node; anything else is one line."""
    name, eq, node = spec.partition("=")
    device = DEVICES.get(name)
    if device is None or (eq and (not device.takes_node or not node)):
        raise UsageError(f"--teleop: {spec!r}; valid: {valid_teleops()}")
    return device, Path(node) if node else None
