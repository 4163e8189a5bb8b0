"""The SpaceMouse at its lowest layer: HID reports written into a FIFO in packet mode (one report per read, as
a hidraw node delivers them), both the older split reports (1 translation, 2 rotation) and the newer six-axis
report 1; out comes the teleop's `delta_eef_gripper` action."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from openral_data.errors import HalError
from openral_data.producers.hal.session.operator import Command
from openral_data.producers.hal.teleop.eef_device import DeviceGains, DeviceReader, DeviceTeleop
from openral_data.producers.hal.teleop.spacemouse import HidrawDecoder, find_spacemouse, open_spacemouse
from openral_data.types import Observation
from tests.support.input_devices import DeviceFifo, hid_axes, hid_buttons, settle, wait_gone

LIMITS = (np.array([-0.05] * 6 + [0.0]), np.array([0.05] * 6 + [1.0]))
OBS = Observation({}, np.zeros(8, dtype=np.float32), "push")
GAINS = DeviceGains(linear=0.02, yaw=0.05, deadzone=0.05, status_every=0)


@pytest.fixture
def mouse(tmp_path: Path) -> Iterator[tuple[DeviceFifo, DeviceReader]]:
    fifo = DeviceFifo(tmp_path / "hidraw3", packets=True)
    reader = open_spacemouse(fifo.path, GAINS)
    yield fifo, reader
    reader.close()
    fifo.unplug()


def test_split_reports_drive_the_end_effector_and_the_buttons_toggle_and_succeed(
    mouse: tuple[DeviceFifo, DeviceReader],
) -> None:
    fifo, reader = mouse
    teleop = DeviceTeleop(reader, LIMITS, GAINS)
    teleop.reset(0)
    fifo.write(hid_axes(1, 175, -350, 10))  # half right, fully away from you, z inside the deadzone
    fifo.write(hid_axes(2, 0, 0, -350))  # twisted counter-clockwise
    fifo.write(hid_buttons(0b01))  # left button: gripper
    settle(reader, 3)
    # x = -ty, y = -tx, yaw = -rz; 175/350 = 0.5 -> (0.5 - 0.05) / 0.95 after the deadzone
    half = (0.5 - 0.05) / 0.95
    np.testing.assert_allclose(teleop.step(OBS, "push"), [0.02, -0.02 * half, 0, 0, 0, 0.05, 1.0], atol=1e-5)
    fifo.write(hid_buttons(0b11))  # right button added: success; the held left one is no new press
    settle(reader, 4)
    assert teleop.command() is Command.SUCCESS and teleop.gripper == 1.0


def test_newer_devices_send_six_axes_in_report_1() -> None:
    dec = HidrawDecoder(deadzone=0.0)
    assert dec.feed(hid_axes(1, 0, 0, -350, 0, 0, 350)) == 1
    np.testing.assert_allclose(dec.motion(), [0, 0, 1.0, -1.0])  # lifted, twisted clockwise
    assert dec.feed(b"\x17\x00") == 0 and dec.feed(b"\x01\x00") == 0  # unknown or short reports: ignored
    np.testing.assert_allclose(dec.motion(), [0, 0, 1.0, -1.0])


def test_a_spacemouse_that_goes_away_ends_the_episode(mouse: tuple[DeviceFifo, DeviceReader]) -> None:
    fifo, reader = mouse
    teleop = DeviceTeleop(reader, LIMITS, GAINS)
    fifo.unplug()
    wait_gone(reader)
    with pytest.raises(HalError, match="spacemouse: the device went away"):
        teleop.step(OBS, "push")


def test_discovery_takes_a_3dconnexion_hidraw_node(tmp_path: Path) -> None:
    dev, sys_hidraw = tmp_path / "dev", tmp_path / "sys"
    dev.mkdir()
    devices = [
        (0, "0003:0000046D:0000C52B", "Logitech USB Receiver"),
        (4, "0003:0000256F:0000C635", "3Dconnexion SpaceMouse Compact"),
    ]
    for n, hid_id, name in devices:
        (dev / f"hidraw{n}").touch()
        (sys_hidraw / f"hidraw{n}" / "device").mkdir(parents=True)
        (sys_hidraw / f"hidraw{n}" / "device" / "uevent").write_text(f"HID_ID={hid_id}\nHID_NAME={name}\n")
    assert find_spacemouse(dev, sys_hidraw) == dev / "hidraw4"
    with pytest.raises(HalError, match="no spacemouse found"):
        find_spacemouse(tmp_path / "none", sys_hidraw)
    with pytest.raises(HalError, match="not a device node"):
        open_spacemouse(dev / "hidraw4")  # a regular file is no device
