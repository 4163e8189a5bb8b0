"""The gamepad at its lowest layer: raw `struct input_event` records written into a FIFO the reader opens as its
evdev node; what comes out is the teleop's `delta_eef_gripper` action (deadzone, gains, gripper toggle,
episode buttons), and a node that goes away ends the episode."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from openral_data.errors import HalError
from openral_data.producers.hal.session.operator import Command
from openral_data.producers.hal.teleop import gamepad
from openral_data.producers.hal.teleop.eef_device import DeviceGains, DeviceReader, DeviceTeleop, shape
from openral_data.producers.hal.teleop.gamepad import EvdevDecoder, find_gamepad, open_gamepad
from openral_data.types import Observation
from tests.support.input_devices import Gamepad, event, settle, syn, wait_gone

LIMITS = (np.array([-0.05] * 6 + [0.0]), np.array([0.05] * 6 + [1.0]))  # scripted-push's bounds
OBS = Observation({}, np.zeros(8, dtype=np.float32), "push")


@pytest.fixture
def pad(tmp_path: Path) -> Iterator[tuple[Gamepad, DeviceReader]]:
    fifo = Gamepad(tmp_path / "event7")
    reader = open_gamepad(fifo.path)
    yield fifo, reader
    reader.close()
    fifo.unplug()


def test_deadzone_reads_rest_as_zero_and_rescales_without_a_jump() -> None:
    assert shape(0.05, 0.1) == 0.0 and shape(-0.1, 0.1) == 0.0
    assert shape(0.1001, 0.1) == pytest.approx(0.0, abs=1e-3)  # continuous at the edge
    assert shape(0.55, 0.1) == pytest.approx(0.5) and shape(-1.0, 0.1) == -1.0
    assert shape(3.0, 0.1) == 1.0  # out-of-range readings saturate


def test_sticks_map_to_world_deltas_with_the_gains(pad: tuple[Gamepad, DeviceReader]) -> None:
    fifo, reader = pad
    gains = DeviceGains(linear=0.02, yaw=0.05, deadzone=0.1, status_every=0)
    teleop = DeviceTeleop(reader, LIMITS, gains)
    teleop.reset(0)
    fifo.sticks(ABS_Y=-1.0, ABS_X=0.55, ABS_RY=0.05)  # forward full, right half, right stick inside the deadzone
    fifo.trigger("ABS_RZ", 255)  # right trigger fully: counter-clockwise
    settle(reader, 2)
    action = teleop.step(OBS, "push")
    assert action.dtype == np.float32
    np.testing.assert_allclose(action, [0.02, -0.01, 0.0, 0.0, 0.0, 0.05, 0.0], atol=1e-4)
    fifo.sticks(ABS_Y=0.0, ABS_X=0.0)
    fifo.trigger("ABS_Z", 255)  # both triggers: they cancel
    settle(reader, 4)
    np.testing.assert_allclose(teleop.step(OBS, "push"), [0, 0, 0, 0, 0, 0, 0], atol=1e-6)


def test_actions_stay_inside_the_contract(pad: tuple[Gamepad, DeviceReader]) -> None:
    fifo, reader = pad
    teleop = DeviceTeleop(reader, (np.full(7, -0.01), np.full(7, 0.01)), DeviceGains(status_every=0))
    teleop.reset(0)
    fifo.sticks(ABS_Y=-1.0)
    settle(reader, 1)
    assert teleop.step(OBS, "push")[0] == pytest.approx(0.01)


def test_south_toggles_the_gripper_and_the_face_buttons_end_episodes(pad: tuple[Gamepad, DeviceReader]) -> None:
    fifo, reader = pad
    teleop = DeviceTeleop(reader, LIMITS, DeviceGains(status_every=0))
    teleop.reset(0)
    fifo.press(gamepad.BTN_SOUTH)
    settle(reader, 2)
    assert teleop.step(OBS, "push")[6] == 1.0  # closed
    fifo.press(gamepad.BTN_SOUTH)
    fifo.press(gamepad.BTN_NORTH)
    settle(reader, 6)
    assert teleop.command() is Command.SUCCESS and teleop.gripper == 0.0
    assert teleop.command() is None  # a press is one command
    fifo.press(gamepad.BTN_EAST)
    settle(reader, 8)
    teleop.reset(1)  # presses between episodes are dropped
    assert teleop.command() is None


def test_axis_values_take_effect_at_the_report_end_and_records_may_arrive_split() -> None:
    dec = EvdevDecoder(dict(gamepad.DEFAULT_RANGES), deadzone=0.0)
    data = event(gamepad.EV_ABS, gamepad.ABS_Y, -32767) + event(gamepad.EV_KEY, gamepad.BTN_NORTH, 1)
    assert dec.feed(data[:30]) == 0 and dec.feed(data[30:]) == 0
    assert dec.motion()[0] == pytest.approx(0.0, abs=1e-4) and dec.take_presses() == []  # not yet reported
    assert dec.feed(syn()) == 1
    assert dec.motion()[0] == pytest.approx(1.0, abs=1e-4) and dec.take_presses() == ["success"]
    # after SYN_DROPPED the kernel's records up to the next report are incomplete: dropped
    dropped = event(gamepad.EV_SYN, gamepad.SYN_DROPPED, 0) + event(gamepad.EV_ABS, gamepad.ABS_Y, 0) + syn()
    dec.feed(dropped)
    assert dec.motion()[0] == pytest.approx(1.0, abs=1e-4)
    dec.feed(event(gamepad.EV_ABS, gamepad.ABS_Y, 0) + event(gamepad.EV_KEY, gamepad.BTN_NORTH, 2) + syn())
    assert dec.motion()[0] == pytest.approx(0.0, abs=1e-4) and dec.take_presses() == []  # auto-repeat: no press


def test_after_lost_records_the_axes_are_read_back_from_the_node() -> None:
    now = {gamepad.ABS_Y: -32767}
    dec = EvdevDecoder(dict(gamepad.DEFAULT_RANGES), deadzone=0.0, resync=lambda: dict(now))
    assert dec.motion()[0] == pytest.approx(1.0, abs=1e-4)  # held forward before the reader started
    now[gamepad.ABS_Y] = 0  # released while records were lost
    dec.feed(event(gamepad.EV_SYN, gamepad.SYN_DROPPED, 0) + syn())
    assert dec.motion()[0] == pytest.approx(0.0, abs=1e-4)


def test_a_fifo_has_no_axis_ranges_so_the_xpad_ones_apply(pad: tuple[Gamepad, DeviceReader]) -> None:
    _, reader = pad
    assert isinstance(reader.decoder, EvdevDecoder) and reader.decoder.ranges == gamepad.DEFAULT_RANGES
    assert gamepad.eviocgabs(gamepad.ABS_X) == 0x80184540  # EVIOCGABS(ABS_X) as <linux/input.h> computes it


def test_a_gamepad_that_goes_away_ends_the_episode(pad: tuple[Gamepad, DeviceReader]) -> None:
    fifo, reader = pad
    teleop = DeviceTeleop(reader, LIMITS, DeviceGains(status_every=0))
    teleop.reset(0)
    fifo.unplug()
    wait_gone(reader)
    with pytest.raises(HalError, match="the device went away") as info:
        teleop.step(OBS, "push")
    assert info.value.code == "hal.teleop"


# (name, capabilities/key, capabilities/abs) as a 64-bit Linux prints them (evtest / udevadm on real machines)
KEYBOARD = ("AT Translated Set 2 keyboard", "402000000 3803078f800d001 feffffdfffefffff fffffffffffffffe", "0")
TOUCHPAD = ("SynPS/2 Synaptics TouchPad", "6420 30000 0 0 0 0", "660800011000003")
ELAN = ("ELAN0670:00 04F3:3150 Touchpad", "e520 10000 0 0 0 0", "661800001000003")
EXTRA = ("ThinkPad Extra Buttons", "10040 0 0 0 0 1000 0 0 0 0 0 0 1 0 0 0", "0")
DS4_TOUCHPAD = ("Wireless Controller Touchpad", "2420 10000 0 0 0 0", "6618000 3")
DS4_MOTION = ("Wireless Controller Motion Sensors", "0", "3f")
DS4 = ("Wireless Controller", "3fff000000000000 0 0 0 0", "3003f")
XBOX = ("Microsoft X-Box 360 pad", "7cdb000000000000 0 0 0 0", "3003f")
STICK = ("Thrustmaster T.16000M", "ffff00000000 0 0 0 0", "30063")


def _sysfs(tmp_path: Path, nodes: list[tuple[int, tuple[str, str, str]]]) -> tuple[Path, Path]:
    """`dev/eventN` and `sys/eventN/device/{name,capabilities/key,capabilities/abs}` laid out as the kernel does."""
    dev, sys_input = tmp_path / "dev", tmp_path / "sys"
    dev.mkdir(parents=True, exist_ok=True)
    for n, (name, key, abs_) in nodes:
        (dev / f"event{n}").touch()
        caps = sys_input / f"event{n}" / "device" / "capabilities"
        caps.mkdir(parents=True)
        (caps.parent / "name").write_text(name + "\n")
        (caps / "key").write_text(key + "\n")
        (caps / "abs").write_text(abs_ + "\n")
    return dev, sys_input


def test_discovery_takes_the_first_node_with_a_gamepad_s_capabilities(tmp_path: Path) -> None:
    nodes = [(1, TOUCHPAD), (2, KEYBOARD), (3, ELAN), (4, EXTRA), (5, DS4_TOUCHPAD), (6, DS4_MOTION), (12, DS4)]
    dev, sys_input = _sysfs(tmp_path, [*nodes, (11, XBOX)])
    assert find_gamepad(dev, sys_input) == dev / "event11"  # numeric order; touchpads, keys, motion skipped
    dev, sys_input = _sysfs(tmp_path / "ds4", nodes)
    assert find_gamepad(dev, sys_input) == dev / "event12"  # the DualShock itself, not its touchpad
    dev, sys_input = _sysfs(tmp_path / "stick", [(3, ELAN), (7, STICK)])
    assert find_gamepad(dev, sys_input) == dev / "event7"  # a joystick (BTN_TRIGGER...) counts too
    assert not any(gamepad.is_gamepad(caps) for _, *caps in (TOUCHPAD, ELAN, EXTRA, DS4_TOUCHPAD, DS4_MOTION))
    dev, sys_input = _sysfs(tmp_path / "none", [(1, TOUCHPAD), (5, DS4_TOUCHPAD), (6, DS4_MOTION)])
    with pytest.raises(HalError, match="no gamepad found") as info:
        find_gamepad(dev, sys_input)
    assert info.value.code == "hal.teleop"
    with pytest.raises(HalError, match="no gamepad found"):
        find_gamepad(tmp_path / "absent", sys_input)
