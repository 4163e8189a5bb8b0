"""A gamepad read from its Linux evdev node (`/dev/input/eventN`) as raw `struct input_event` records.

Each record is 24 bytes on a 64-bit kernel: `struct timeval` (two longs), `__u16 type`, `__u16 code`,
`__s32 value`. `EV_ABS` records move an axis, `EV_KEY` records press (1), release (0) or auto-repeat (2) a
button, and `EV_SYN`/`SYN_REPORT` closes one report: axis values take effect at the report's end, as the kernel
means them to; after `SYN_DROPPED` (the reader fell behind) records are dropped up to the next report, and the
axes are read back from the node.

We decode the records ourselves (struct) instead of using python-evdev's `InputDevice`, which issues ioctls on
open (EVIOCGNAME, EVIOCGVERSION, ...) that only a real evdev node answers, and instead of lerobot 0.6.1's
`GamepadTeleop`, whose pygame (SDL) and hidapi back ends need a real device and SDL's joystick subsystem: the
device node is the lowest layer that exists everywhere, and a FIFO can stand in for it in tests. An axis's range
comes from the node itself (the EVIOCGABS ioctl); where the node does not answer it (a FIFO), the Linux xpad
driver's ranges are assumed: sticks -32768..32767, triggers 0..255.

Mapping (Linux gamepad API names; docs/record-your-robot.md has the table): left stick forward/back ±x,
left/right ±y (left is +y); right stick up/down ±z; right trigger minus left trigger ±yaw; the south button
(A / cross) toggles the gripper; north (Y / triangle) success, east (B / circle) failure, west (X / square)
re-record, left shoulder discard, select (back / share) quit; the right shoulder (RB / R1) takes over from the
policy and hands back in an intervention session (`record --rskill R --teleop gamepad`; ignored otherwise).
"""

from __future__ import annotations

import contextlib
import fcntl
import struct
from collections.abc import Callable, Sequence
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

EVENT = struct.Struct("llHHi")  # struct input_event: tv_sec, tv_usec, type, code, value (native, 24 bytes)
ABSINFO = struct.Struct("6i")  # struct input_absinfo: value, minimum, maximum, fuzz, flat, resolution
EV_SYN, EV_KEY, EV_ABS = 0x00, 0x01, 0x03
SYN_REPORT, SYN_DROPPED = 0, 3
ABS_X, ABS_Y, ABS_Z, ABS_RX, ABS_RY, ABS_RZ = 0x00, 0x01, 0x02, 0x03, 0x04, 0x05
BTN_SOUTH, BTN_EAST, BTN_NORTH, BTN_WEST, BTN_TL, BTN_TR, BTN_SELECT = 0x130, 0x131, 0x133, 0x134, 0x136, 0x137, 0x13A
STICKS = (ABS_X, ABS_Y, ABS_RX, ABS_RY)
TRIGGERS = (ABS_Z, ABS_RZ)
DEFAULT_RANGES = {**dict.fromkeys(STICKS, (-32768, 32767)), **dict.fromkeys(TRIGGERS, (0, 255))}  # xpad's
BUTTONS: dict[int, str] = {
    BTN_SOUTH: GRIPPER,
    BTN_NORTH: Command.SUCCESS.value,
    BTN_EAST: Command.FAILURE.value,
    BTN_WEST: Command.RERECORD.value,
    BTN_TL: Command.DISCARD.value,
    BTN_SELECT: Command.QUIT.value,
    BTN_TR: TAKEOVER,
}
TAKEOVER_CONTROL = "RB"  # the right shoulder button
GAINS = DeviceGains(deadzone=0.1)  # a stick at rest reads up to a few % off centre
DEV_INPUT = Path("/dev/input")
SYS_INPUT = Path("/sys/class/input")
# udev's input_id: a joystick or gamepad has a button of the BTN_JOYSTICK (0x120..) or BTN_GAMEPAD (0x130..0x13e)
# block and the ABS_X/ABS_Y axes; a touchpad (a laptop's, a DualShock's) has BTN_TOOL_FINGER/BTN_TOUCH instead
PAD_BUTTONS = range(0x120, 0x13F)
BTN_TOOL_FINGER, BTN_TOUCH = 0x145, 0x14A
CAPABILITIES = ("capabilities/key", "capabilities/abs")
WORD_BITS = struct.calcsize("l") * 8  # sysfs prints a bitmap as hex longs, the most significant first
WHAT = "gamepad"


def eviocgabs(code: int) -> int:
    """The EVIOCGABS(code) request: _IOR('E', 0x40 + code, struct input_absinfo)."""
    return (2 << 30) | (ABSINFO.size << 16) | (ord("E") << 8) | (0x40 + code)


def absinfo(fd: int) -> dict[int, tuple[int, int, int]]:
    """Each axis's (value now, minimum, maximum) as the evdev node reports it (EVIOCGABS); the axes it does not
    answer for (all of them on a FIFO: ENOTTY) are left out."""
    info: dict[int, tuple[int, int, int]] = {}
    for code in DEFAULT_RANGES:
        with contextlib.suppress(OSError):  # ENOTTY: not an evdev node (a FIFO); EINVAL: no such axis
            value, low, high, *_ = ABSINFO.unpack(fcntl.ioctl(fd, eviocgabs(code), bytes(ABSINFO.size)))
            if high > low:
                info[code] = (value, low, high)
    return info


def axis_ranges(fd: int) -> dict[int, tuple[int, int]]:
    """Each axis's (minimum, maximum) as the evdev node reports it; the xpad defaults where it does not answer."""
    return {**DEFAULT_RANGES, **{code: (low, high) for code, (_, low, high) in absinfo(fd).items()}}


class EvdevDecoder(Presses):
    """`struct input_event` records -> stick/trigger values and button presses (see the module docstring).

    `resync` gives the axes' values now (the node's EVIOCGABS): the start values, and the values after a
    `SYN_DROPPED` (records were lost, so an axis's last record may be missing); without it (a FIFO) the sticks
    start centred, the triggers released, and lost records stay lost until the axis moves again."""

    def __init__(
        self,
        ranges: dict[int, tuple[int, int]],
        deadzone: float,
        resync: Callable[[], dict[int, int]] | None = None,
    ) -> None:
        super().__init__()
        self.ranges, self.deadzone, self.resync = ranges, deadzone, resync
        self.raw: dict[int, int] = {c: (lo + hi + 1) // 2 if c in STICKS else lo for c, (lo, hi) in ranges.items()}
        if resync is not None:
            self.raw.update(resync())
        self._frame: dict[int, int] = {}  # axis values of the report being read
        self._pressed: list[str] = []  # presses of the report being read
        self._buffer = b""
        self._dropping = False

    def feed(self, data: bytes) -> int:
        self._buffer += data
        n = len(self._buffer) // EVENT.size * EVENT.size
        reports = sum(self._event(kind, code, value) for _, _, kind, code, value in EVENT.iter_unpack(self._buffer[:n]))
        self._buffer = self._buffer[n:]
        return reports

    def _event(self, kind: int, code: int, value: int) -> bool:
        if kind == EV_SYN and code == SYN_DROPPED:
            self._dropping, self._frame, self._pressed = True, {}, []
        elif kind == EV_SYN and code == SYN_REPORT:
            if not self._dropping:
                self.raw.update(self._frame)
                self._presses += self._pressed
            elif self.resync is not None:
                self.raw.update(self.resync())
            self._dropping, self._frame, self._pressed = False, {}, []
            return True
        elif kind == EV_ABS and code in self.ranges:
            self._frame[code] = value
        elif kind == EV_KEY and value == 1 and code in BUTTONS:
            self._pressed.append(BUTTONS[code])
        return False

    def stick(self, code: int) -> float:
        low, high = self.ranges[code]
        centre, half = (low + high) / 2, (high - low) / 2
        return shape((self.raw[code] - centre) / half, self.deadzone)

    def trigger(self, code: int) -> float:
        low, high = self.ranges[code]
        return shape((self.raw[code] - low) / (high - low), self.deadzone)

    def motion(self) -> npt.NDArray[np.float64]:
        """(x, y, z, yaw): stick up is a negative ABS_Y, so forward = -ABS_Y; left = -ABS_X is +y; right stick
        up = +z; right trigger - left trigger = +yaw (counter-clockwise seen from above)."""
        yaw = self.trigger(ABS_RZ) - self.trigger(ABS_Z)
        return np.array([-self.stick(ABS_Y), -self.stick(ABS_X), -self.stick(ABS_RY), yaw])


def bitmap(text: str) -> int:
    """A sysfs capability bitmap (`7cdb000000000000 0 0 0 0`: hex longs, the most significant first) as one int."""
    value = 0
    for word in text.split():
        value = (value << WORD_BITS) | int(word, 16)
    return value


def is_gamepad(capabilities: Sequence[str]) -> bool:
    """An evdev node's `capabilities/key` and `capabilities/abs` are a gamepad's or a joystick's (udev's
    input_id test): a gamepad or joystick button, the X and Y axes, and no touch (a touchpad's finger)."""
    keys, axes = (bitmap(text) for text in capabilities)
    button = any(keys >> code & 1 for code in PAD_BUTTONS)
    touch = keys >> BTN_TOUCH & 1 or keys >> BTN_TOOL_FINGER & 1
    return button and not touch and axes >> ABS_X & 1 == 1 and axes >> ABS_Y & 1 == 1


def find_gamepad(dev: Path = DEV_INPUT, sys_input: Path = SYS_INPUT) -> Path:
    """The first `eventN` under `dev` whose capabilities (`sys_input`/eventN/device/capabilities/key, abs) are a
    gamepad's (`is_gamepad`); its name is not looked at (touchpads and extra-button nodes have names like pads)."""
    return find_node(dev, "event", sys_input, CAPABILITIES, is_gamepad, WHAT)


def open_gamepad(path: Path | None, gains: DeviceGains = GAINS) -> DeviceReader:
    """Open the gamepad at `path` (default: the first one found) and start reading it."""
    node = path if path is not None else find_gamepad()
    fd = open_node(node, f"--teleop {WHAT}")
    decoder = EvdevDecoder(axis_ranges(fd), gains.deadzone, lambda: {c: v for c, (v, _, _) in absinfo(fd).items()})
    return DeviceReader(node, fd, decoder, WHAT)


def open_teleop(request: DeviceRequest) -> DeviceTeleop:
    """`--teleop gamepad[=NODE]`: the gamepad driving the rSkill's `delta_eef_gripper` action."""
    return device_teleop(request, WHAT, GAINS, lambda: open_gamepad(request.node, GAINS))


KEYS = (
    "gamepad: left stick +x/-x (forward/back) and +y/-y (left/right) · right stick +z/-z (up/down) · "
    "RT-LT yaw · A gripper · Y success · B failure · X re-record · LB discard · select quit"
)
DEVICE = TeleopDevice(WHAT, open_teleop, TAKEOVER_CONTROL, takes_node=True, keys=KEYS)
