"""Stand-ins for input device nodes: a FIFO the real CLI opens as its `/dev/input/eventN` or `/dev/hidrawN`, and
the test writing what the kernel would (raw `struct input_event` records, or HID reports one per read)."""

from __future__ import annotations

import fcntl
import os
import struct
import time
from pathlib import Path

from openral_data.producers.hal.teleop import gamepad
from openral_data.producers.hal.teleop.eef_device import DeviceReader

EVENT = struct.Struct("llHHi")
STICK_MAX = 32767


def event(kind: int, code: int, value: int) -> bytes:
    return EVENT.pack(0, 0, kind, code, value)


def syn() -> bytes:
    return event(gamepad.EV_SYN, gamepad.SYN_REPORT, 0)


class DeviceFifo:
    """The writing end of a FIFO at `path`, held open (O_RDWR: opening never blocks on a reader) until `unplug`;
    `packets`: every write is one read for the reader (pipe packet mode, as a hidraw node delivers reports)."""

    def __init__(self, path: Path, packets: bool = False) -> None:
        os.mkfifo(path)
        self.path = path
        self.fd: int | None = os.open(path, os.O_RDWR)
        if packets:
            fcntl.fcntl(self.fd, fcntl.F_SETFL, fcntl.fcntl(self.fd, fcntl.F_GETFL) | os.O_DIRECT)

    def write(self, data: bytes) -> None:
        assert self.fd is not None
        os.write(self.fd, data)

    def unplug(self) -> None:
        """Close the writer: the reader sees end of file, as a read on an unplugged evdev node fails."""
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None


class Gamepad(DeviceFifo):
    """A gamepad as its evdev node shows it: axes in [-1, 1] (sticks; the xpad ranges) and button presses."""

    def sticks(self, **axes: float) -> None:
        """`sticks(ABS_X=0.5, ABS_Y=-1.0)`: one report moving those axes (fractions of full deflection)."""
        records = b"".join(
            event(gamepad.EV_ABS, getattr(gamepad, name), round(v * STICK_MAX)) for name, v in axes.items()
        )
        self.write(records + syn())

    def trigger(self, name: str, value: int) -> None:
        self.write(event(gamepad.EV_ABS, getattr(gamepad, name), value) + syn())

    def press(self, button: int) -> None:
        """Press and release `button`, two reports."""
        self.write(event(gamepad.EV_KEY, button, 1) + syn() + event(gamepad.EV_KEY, button, 0) + syn())


def hid_axes(report: int, *values: int) -> bytes:
    return bytes([report]) + struct.pack(f"<{len(values)}h", *values)


def hid_buttons(mask: int) -> bytes:
    return bytes([3, mask & 0xFF, mask >> 8 & 0xFF])


def settle(reader: DeviceReader, reports: int) -> None:
    """Wait until the reader thread has applied `reports` complete reports."""
    end = time.monotonic() + 5
    while reader.reports < reports:
        assert time.monotonic() < end, f"the reader saw {reader.reports} of {reports} reports"
        time.sleep(0.005)


def wait_gone(reader: DeviceReader) -> None:
    """Wait until the reader thread has seen its device go away."""
    end = time.monotonic() + 5
    while reader.gone is None:
        assert time.monotonic() < end, "the reader never saw the device go"
        time.sleep(0.005)
