"""A 3Dconnexion SpaceMouse read from its Linux hidraw node (`/dev/hidrawN`) as raw HID input reports.

A hidraw node hands out one report per `read()`, its first byte the report id:

* report 1: translation x, y, z as three little-endian int16; newer devices (SpaceMouse Wireless, Compact and
  later) send all six axes in it, translation then rotation rx, ry, rz (13 bytes instead of 7);
* report 2: rotation rx, ry, rz (older devices: SpaceNavigator, SpaceMouse Pro);
* report 3: the buttons, a bit mask from byte 1 (bit 0 the left button, bit 1 the right one).

Values reach about ±350 at full deflection (`FULL_SCALE`). 3Dconnexion's axes: +x right, +y towards you, +z
down, +rz clockwise seen from above; so pushing the cap away from you is +x, to the left +y, lifting it +z and
twisting it counter-clockwise +yaw. The left button toggles the gripper, the right one marks success; in an
intervention session (`record --rskill R --teleop spacemouse`) the right one takes over from the policy and hands
back instead (a SpaceMouse has two buttons: the episode then ends by the scene, the step limit or the keys).

We read the node itself rather than through hidapi (`hid`, not installed here) or lerobot (it has no SpaceMouse
teleoperator): hidraw is the lowest layer there is, needs no library, and a FIFO can stand in for it in tests
(written in packet mode, one report per read, as hidraw delivers them).
"""

from __future__ import annotations

import re
import struct
from pathlib import Path

import numpy as np
import numpy.typing as npt

from openral_data.producers.hal.session.operator import Command
from openral_data.producers.hal.teleop.declare import DeviceRequest, TeleopDevice
from openral_data.producers.hal.teleop.eef_device import (
    GRIPPER,
    TAKEOVER,
    DeviceGains,
    DeviceReader,
    DeviceTeleop,
    Presses,
    device_teleop,
    find_node,
    open_node,
    shape,
)

AXES3 = struct.Struct("<3h")
FULL_SCALE = 350.0
TRANSLATION, ROTATION, BUTTONS = 1, 2, 3
BUTTON_NAMES = {0: GRIPPER, 1: Command.SUCCESS.value}  # bit -> what a press does
TAKEOVER_BUTTONS = {0: GRIPPER, 1: TAKEOVER}  # an intervention session's
TAKEOVER_CONTROL = "the right button"
GAINS = DeviceGains(deadzone=0.05)  # the cap at rest reads a few counts off zero
DEV = Path("/dev")
SYS_HIDRAW = Path("/sys/class/hidraw")
VENDORS = ("0000046D", "0000256F")  # Logitech (older 3Dconnexion devices), 3Dconnexion
SPACEMOUSE_NAME = re.compile(r"3dconnexion|spacemouse|spacenavigator|spacepilot|spaceexplorer", re.I)
WHAT = "spacemouse"


class HidrawDecoder(Presses):
    """SpaceMouse HID reports -> six axes and button presses (see the module docstring)."""

    def __init__(self, deadzone: float, buttons: dict[int, str] | None = None) -> None:
        super().__init__()
        self.deadzone = deadzone
        self.names = BUTTON_NAMES if buttons is None else buttons
        self.translation = (0, 0, 0)
        self.rotation = (0, 0, 0)
        self.buttons = 0

    def feed(self, data: bytes) -> int:
        """One report (one hidraw read); unknown or short reports are ignored."""
        report, body = data[:1], data[1:]
        if report == bytes([TRANSLATION]) and len(body) >= AXES3.size:
            self.translation = AXES3.unpack_from(body)
            if len(body) >= 2 * AXES3.size:  # newer devices: rotation in the same report
                self.rotation = AXES3.unpack_from(body, AXES3.size)
        elif report == bytes([ROTATION]) and len(body) >= AXES3.size:
            self.rotation = AXES3.unpack_from(body)
        elif report == bytes([BUTTONS]) and body:
            mask = int.from_bytes(body[:4], "little")
            pressed = mask & ~self.buttons
            self._presses += [name for bit, name in self.names.items() if pressed >> bit & 1]
            self.buttons = mask
        else:
            return 0
        return 1

    def axis(self, raw: int) -> float:
        return shape(raw / FULL_SCALE, self.deadzone)

    def motion(self) -> npt.NDArray[np.float64]:
        """(x, y, z, yaw) in the world: away from you (-y raw), left (-x raw), up (-z raw), counter-clockwise
        (-rz raw)."""
        tx, ty, tz = self.translation
        return np.array([-self.axis(ty), -self.axis(tx), -self.axis(tz), -self.axis(self.rotation[2])])


def is_spacemouse(uevent: str) -> bool:
    """A HID device's uevent (`HID_ID=0003:0000256F:0000C635`, `HID_NAME=3Dconnexion SpaceMouse Compact`) is a
    3Dconnexion one."""
    fields = dict(line.partition("=")[::2] for line in uevent.splitlines())
    vendor = [*fields.get("HID_ID", "").split(":"), "", ""][1].upper()
    return vendor in VENDORS and SPACEMOUSE_NAME.search(fields.get("HID_NAME", "")) is not None


def find_spacemouse(dev: Path = DEV, sys_hidraw: Path = SYS_HIDRAW) -> Path:
    """The first `hidrawN` under `dev` whose HID device (`sys_hidraw`/hidrawN/device/uevent) is a 3Dconnexion one."""
    return find_node(dev, "hidraw", sys_hidraw, ("uevent",), lambda texts: is_spacemouse(texts[0]), WHAT)


def open_spacemouse(path: Path | None, gains: DeviceGains = GAINS, takeover: bool = False) -> DeviceReader:
    """Open the SpaceMouse at `path` (default: the first one found) and start reading it; `takeover`: the right
    button takes over (an intervention session) instead of marking success."""
    node = path if path is not None else find_spacemouse()
    decoder = HidrawDecoder(gains.deadzone, TAKEOVER_BUTTONS if takeover else None)
    return DeviceReader(node, open_node(node, f"--teleop {WHAT}"), decoder, WHAT)


def open_teleop(request: DeviceRequest) -> DeviceTeleop:
    """`--teleop spacemouse[=NODE]`: the spacemouse driving the rSkill's `delta_eef_gripper` action
    (in an intervention session its right button takes over instead of marking success)."""
    return device_teleop(request, WHAT, GAINS, lambda: open_spacemouse(request.node, GAINS, request.takeover))


KEYS = (
    "spacemouse: push the cap away/toward you +x/-x, left/right +y/-y, lift/press +z/-z, twist yaw · "
    "left button gripper · right button success"
)
DEVICE = TeleopDevice(WHAT, open_teleop, TAKEOVER_CONTROL, takes_node=True, keys=KEYS)
