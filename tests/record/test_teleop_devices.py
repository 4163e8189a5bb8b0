"""`record --scene tabletop_push --teleop gamepad=NODE | spacemouse=NODE`: a person with a gamepad or a
SpaceMouse drives the scene.

No device, no /dev/uinput here: the device node the real CLI opens is a FIFO, and this test is the person and
the kernel at once. It reads the status lines the teleop prints on stderr (where the gripper is), and moves the
stick (raw `struct input_event` records, evdev) or the cap (HID reports, hidraw) toward the next waypoint,
closed loop, until the scene ends the episode with the cube in the goal. The recording then replays exactly
(`replay --mode actions`) and says who drove. A device that goes away mid-run ends the run with one line,
the committed episodes kept; a missing one is one line before anything is written.
"""

from __future__ import annotations

import contextlib
import os
import re
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from openral_data.producers.hal.teleop import gamepad, spacemouse
from tests.support.hal import episode_infos
from tests.support.inproc import run_inproc
from tests.support.input_devices import DeviceFifo, Gamepad, hid_axes, hid_buttons
from tests.support.pty_terminal import Terminal
from tests.support.teleop_push import ended, push_waypoints, pushed, replays_exactly

F64 = npt.NDArray[np.float64]
SEED = 0
STATUS = re.compile(rb"eef (-?\d+\.\d+) (-?\d+\.\d+) (-?\d+\.\d+) gripper (open|closed)\r*\n")  # a pty adds \r
LINEAR = gamepad.GAINS.linear  # m per tick at full deflection (the same for both devices)


class Device:
    """What the person does with the device: `move(u)` holds a deflection u (x, y, z in [-1, 1] of the
    world motion, before the deadzone) until the next move; `grip()` presses the gripper button."""

    def __init__(self, kind: str, path: Path) -> None:
        self.kind = kind
        self.fifo = Gamepad(path) if kind == "gamepad" else DeviceFifo(path, packets=True)
        self.deadzone = (gamepad.GAINS if kind == "gamepad" else spacemouse.GAINS).deadzone

    def raw(self, u: float) -> float:
        """The deflection that reads as `u` after the deadzone."""
        return 0.0 if u == 0 else float(np.sign(u)) * (self.deadzone + (1 - self.deadzone) * min(1.0, abs(u)))

    def move(self, u: F64) -> None:
        x, y, z = (self.raw(float(v)) for v in u)
        if isinstance(self.fifo, Gamepad):  # forward = -ABS_Y, left = -ABS_X, up = -ABS_RY
            self.fifo.sticks(ABS_Y=-x, ABS_X=-y, ABS_RY=-z)
        else:  # away = -ty, left = -tx, up = -tz
            self.fifo.write(hid_axes(1, *(round(-v * spacemouse.FULL_SCALE) for v in (y, x, z))))

    def grip(self) -> None:
        if isinstance(self.fifo, Gamepad):
            self.fifo.press(gamepad.BTN_SOUTH)
        else:
            self.fifo.write(hid_buttons(0b01))
            self.fifo.write(hid_buttons(0b00))


class Stderr(Terminal):
    """The CLI's stderr as it comes, on a pty (status lines go to a terminal only): the status and episode lines."""

    def position(self, after: int) -> tuple[F64 | None, int]:
        found = list(STATUS.finditer(self.text, after))
        if not found:
            return None, after
        m = found[-1]
        return np.array([float(m.group(k)) for k in (1, 2, 3)]), m.end()


def _drive_to(device: Device, err_out: Stderr, target: F64, tol: float, running: Callable[[], bool]) -> None:
    """Deflect toward `target` in proportion to the distance left (full deflection from 4 ticks' travel away),
    on every new status line, until it is reached (or the scene ended the episode)."""
    seen, end = len(err_out.text), time.monotonic() + 30
    while time.monotonic() < end and running():
        err_out.read(0.05)
        pos, at = err_out.position(seen)
        if pos is None:
            continue
        seen = at
        err = target - pos
        if np.all(np.abs(err) < tol):
            device.move(np.zeros(3))
            return
        device.move(np.clip(err / (4 * LINEAR), -1.0, 1.0))
    if running():
        raise AssertionError(f"never reached {target}: {err_out.text[-3000:].decode(errors='replace')}")


@contextlib.contextmanager
def _running(proc: subprocess.Popen[bytes], err_fd: int, device: DeviceFifo) -> Iterator[Stderr]:
    """The recording's stderr (the pty's far side `err_fd`) while it runs; afterwards the process is gone (killed
    if it still ran), the pty closed and the device unplugged."""
    err_out = Stderr(err_fd)
    try:
        yield err_out
        proc.wait(timeout=30)
        err_out.read(0.2)
    finally:
        ended(proc)
        os.close(err_fd)
        device.unplug()


def _record(kind: str, node: Path, out: Path, *extra: str) -> tuple[subprocess.Popen[bytes], int]:
    """The recording, its stderr a pty (as a person's terminal); the pty's far side is returned with it."""
    args = ["record", "--scene", "tabletop_push", "--teleop", f"{kind}={node}", "--out", str(out), "--codec", "h264"]
    master, slave = os.openpty()
    proc = subprocess.Popen(
        [sys.executable, "-m", "openral_data.cli", *args, "--seed", str(SEED), *extra],
        stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=slave,
        env={**os.environ, "MUJOCO_GL": "egl"}, close_fds=True,
    )  # fmt: skip
    os.close(slave)
    return proc, master


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["gamepad", "spacemouse"])
def test_a_person_with_a_device_pushes_the_cube_and_the_episode_replays(
    kind: str, project: Path, tmp_path: Path
) -> None:
    waypoints = push_waypoints(SEED)
    out, device = tmp_path / "teleop", Device(kind, tmp_path / "node")
    proc, err_fd = _record(kind, device.fifo.path, out, "--n-episodes", "1", "--max-steps", "600")
    with _running(proc, err_fd, device.fifo) as err_out:
        err_out.wait_for(b"gripper open", 60)  # the episode runs: close the gripper, closed fingers push
        device.grip()
        for k, target in enumerate(waypoints):
            _drive_to(device, err_out, target, 0.008 if k == 0 else 0.012, lambda: proc.poll() is None)
    actions = pushed(out, proc.returncode, err_out.text, f"teleop:{kind}")
    assert np.abs(actions[:, :3]).max() <= LINEAR + 1e-6
    assert set(actions[:, 6]) <= {0.0, 1.0} and actions[-1, 6] == 1.0  # toggled closed, and it stayed
    assert len(set(np.round(actions[:, 0], 5))) > 5  # analog: many speeds, not whole steps
    replays_exactly(out, tmp_path / "res")


@pytest.mark.slow
def test_a_gamepad_unplugged_mid_run_discards_the_episode_and_keeps_the_committed_ones(
    project: Path, tmp_path: Path
) -> None:
    out, pad = tmp_path / "teleop", Gamepad(tmp_path / "event5")
    proc, err_fd = _record(
        "gamepad", pad.path, out, "--n-episodes", "3", "--operator", "success@5", "--max-steps", "400"
    )
    with _running(proc, err_fd, pad) as err_out:
        err_out.wait_for(b"episode 1/3: kept", 60)
        pad.unplug()
    lines = err_out.text.decode(errors="replace").strip().splitlines()
    assert proc.returncode == 2, lines[-20:]
    assert lines[-1].startswith(f"error: {pad.path}: gamepad: the device went away"), lines[-5:]
    assert f"(1 finished episode(s) kept in {out})" in lines[-1]
    infos = episode_infos(out)
    assert len(infos) == 1 and infos[0]["operator"] == "teleop:gamepad" and infos[0]["hal"]["verdict"] == "success"


@pytest.mark.parametrize("kind", ["gamepad", "spacemouse"])
def test_a_missing_device_is_one_line_before_anything_is_written(kind: str, project: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    r = run_inproc("record", "--scene", "tabletop_push", "--teleop", f"{kind}={tmp_path}/gone", "--out", str(out))
    assert r.returncode == 2, r.stderr
    what = "no such device (No such file or directory); is it plugged in?"
    assert r.stderr.splitlines() == [f"error: {tmp_path}/gone: --teleop {kind}: {what}"]
    assert not out.exists()


def test_no_device_found_and_a_malformed_teleop_are_one_line(project: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    r = run_inproc("record", "--scene", "tabletop_push", "--teleop", "gamepad", "--out", str(out))
    if Path("/dev/input").exists() and any(Path("/dev/input").glob("event*")):
        pytest.skip("this machine has input devices; discovery is covered by tests/producers/test_gamepad.py")
    assert (r.returncode, r.stderr.count("\n")) == (2, 1) and "no gamepad found" in r.stderr, r.stderr
    for bad in ("gamepad=", "joystick"):
        r = run_inproc("record", "--scene", "tabletop_push", "--teleop", bad, "--out", str(out))
        assert (r.returncode, r.stderr.count("\n")) == (2, 1) and "--teleop: " in r.stderr, r.stderr
    assert not out.exists()
