"""An end-effector input device (gamepad, SpaceMouse) read on its own thread, as the producer of actions.

The device node (`/dev/input/eventN`, `/dev/hidrawN`) is opened before episode 0 and read by a `DeviceReader`
thread: every `read()` goes to the device's `Decoder` (producers/hal/teleop/gamepad.py, spacemouse.py), which keeps
the newest axis values and the button presses; the reader counts the complete reports.
`DeviceTeleop` is a policy (reset / step / close, the `PolicyAdapter` protocol): each tick it turns the axes
(already shaped by the deadzone, in [-1, 1]) into a `delta_eef_gripper` action [dx, dy, dz, 0, 0, dyaw,
gripper] = gains × axes, clipped to the contract; the gripper button toggles the gripper (0 open, 1 closed).
In an intervention session (policies/intervention.py) the takeover button calls `on_takeover` (the switch:
the policy drives until a press, the device until the next) and `take_over` keeps the policy's gripper.
Buttons that end an episode (success, failure, re-record, discard, quit) reach the loop through
`DeviceOperator`, which wraps the run's operator (`--operator auto`, a script, or the terminal keys).

A device that goes away (end of file, ENODEV: unplugged) makes the next `step()` raise `HalError`
(`hal.teleop`): the episode in flight is discarded, the committed ones are kept, the run ends with one line.
"""

from __future__ import annotations

import contextlib
import errno
import os
import stat
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Protocol

import numpy as np
import numpy.typing as npt

from openral_data.errors import HalError
from openral_data.paths import read_regular
from openral_data.producers.hal.session.operator import PAUSE_ENDS, Command, Operator, no_check, sliced_wait
from openral_data.producers.hal.teleop.declare import Buttons, DeviceRequest
from openral_data.producers.hal.teleop.keyboard import eef_limits, held_gripper
from openral_data.producers.hal.teleop.status import eef_line, status_lines
from openral_data.types import Observation

GRIPPER = "gripper"  # the button name that toggles the gripper; the others name a `Command` or:
TAKEOVER = "takeover"  # the button that hands control to the person and back (interventions); else ignored
READ_SIZE = 4096
POLL_S = 0.05  # how often the reader thread looks whether it should stop


@dataclass(frozen=True)
class DeviceGains:
    """How far full deflection moves the end effector per tick, and how much of it reads as rest."""

    linear: float = 0.02  # m per tick along x, y, z at full deflection (the keyboard's max_step)
    yaw: float = 0.05  # rad per tick about world z at full deflection
    deadzone: float = 0.1  # fraction of full deflection read as 0; the rest rescaled to 0..1
    status_every: int = 2  # ticks between status lines (0: none)

    def scaled(self, gain: float) -> DeviceGains:
        """`record --teleop-gain G`: full deflection moves G times as far per tick."""
        return replace(self, linear=self.linear * gain, yaw=self.yaw * gain)


def shape(value: float, deadzone: float) -> float:
    """One axis value in [-1, 1] with its deadzone: |v| <= deadzone -> 0, then linear up to ±1 (no jump at the
    deadzone's edge)."""
    v = min(1.0, max(-1.0, value))
    if abs(v) <= deadzone:
        return 0.0
    return float(np.sign(v)) * (abs(v) - deadzone) / (1.0 - deadzone)


class Decoder(Protocol):
    """A device's bytes -> its state. `feed` takes what one `read()` returned and says how many complete reports
    it applied; `motion` is (x, y, z, yaw) in [-1, 1] after the deadzone; `take_presses` hands out (and
    forgets) the buttons pressed since the last call, by name (`GRIPPER`, `TAKEOVER` or a `Command` value)."""

    def feed(self, data: bytes) -> int: ...

    def motion(self) -> npt.NDArray[np.float64]: ...

    def take_presses(self) -> list[str]: ...


class Presses:
    """The button presses a decoder has seen and nobody has taken yet."""

    def __init__(self) -> None:
        self._presses: list[str] = []

    def take_presses(self) -> list[str]:
        presses, self._presses = self._presses, []
        return presses


def find_node(
    dev: Path,
    prefix: str,
    sys_class: Path,
    info: Sequence[str],
    looks_like: Callable[[Sequence[str]], bool],
    what: str,
) -> Path:
    """The first `dev`/<prefix>N (in N's order) whose `sys_class`/<prefix>N/device/`info` files (sysfs: each read
    bounded, a regular file only) `looks_like` the device wanted; none is one line (`hal.teleop`)."""
    numbered = [(int(p.name[len(prefix) :]), p) for p in dev.glob(prefix + "*") if p.name[len(prefix) :].isdigit()]
    for _, node in sorted(numbered):
        with contextlib.suppress(OSError, ValueError):
            folder = sys_class / node.name / "device"
            texts = [read_regular(folder / name, limit=1 << 14).decode(errors="replace") for name in info]
            if looks_like(texts):
                return node  # open_node checks that it is a device node
    files = " and ".join(f"{sys_class}/{prefix}N/device/{name}" for name in info)
    raise HalError(
        f"{dev}: --teleop {what}: no {what} found (no {prefix}N whose {files} says it is one); plug one in, "
        f"or name its node: --teleop {what}={dev}/{prefix}N",
        code="hal.teleop",
    )


def open_node(path: Path, what: str) -> int:
    """Open a device node for reading without blocking (a character device, or a FIFO standing in for one)."""
    try:
        mode = os.stat(path).st_mode
    except OSError as exc:
        raise HalError(
            f"{path}: {what}: no such device ({exc.strerror}); is it plugged in?", code="hal.teleop"
        ) from exc
    if not (stat.S_ISCHR(mode) or stat.S_ISFIFO(mode)):
        raise HalError(f"{path}: {what}: not a device node (a character device)", code="hal.teleop")
    try:
        return os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except OSError as exc:
        hint = " (add yourself to the group owning it, or a udev rule)" if exc.errno == errno.EACCES else ""
        raise HalError(f"{path}: {what}: cannot open: {exc.strerror}{hint}", code="hal.teleop") from exc


class DeviceReader:
    """Reads the device on its own thread; `decoder` holds the newest state, guarded by `lock`."""

    def __init__(self, path: Path, fd: int, decoder: Decoder, what: str) -> None:
        self.path, self.fd, self.decoder, self.what = path, fd, decoder, what
        self.lock = threading.Lock()
        self.reports = 0  # complete reports applied (`settle` in tests/support/input_devices.py waits on it)
        self.gone: str | None = None  # why the device stopped delivering (unplugged, read error)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"teleop-{what}", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        import select

        while not self._stop.is_set():
            ready, _, _ = select.select([self.fd], [], [], POLL_S)
            if not ready:
                continue
            try:
                data = os.read(self.fd, READ_SIZE)
            except BlockingIOError:
                continue
            except OSError as exc:  # ENODEV: the device was unplugged
                self._lost(exc.strerror or str(exc))
                return
            if not data:  # end of file: the device (or the FIFO's writer) went away
                self._lost("end of file")
                return
            with self.lock:
                self.reports += self.decoder.feed(data)

    def _lost(self, why: str) -> None:
        with self.lock:
            self.gone = why

    def close(self) -> None:
        """Stop the thread and close the node; once (a second call must not close a reused descriptor)."""
        if self._stop.is_set():
            return
        self._stop.set()
        self._thread.join(timeout=1.0)
        with contextlib.suppress(OSError):
            os.close(self.fd)


class DeviceTeleop:
    """The device's axes and buttons -> `delta_eef_gripper` actions [dx, dy, dz, 0, 0, dyaw, gripper]."""

    def __init__(
        self,
        reader: DeviceReader,
        limits: tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]],
        gains: DeviceGains,
        show: Callable[[str], None] | None = None,
    ) -> None:
        self.low, self.high = limits  # the contract's bounds (`teleop.eef_limits`)
        self.reader, self.gains, self.show = reader, gains, show
        self.type_name = reader.what  # `operator` in the episode's record: teleop:<type_name>
        self.gripper = 0.0
        self.ticks = 0
        self._command: Command | None = None
        self.on_takeover: Callable[[], None] | None = None  # an intervention's switch (`device_switch`)

    def _drain(self) -> None:
        """Apply the buttons pressed since the last look, in order: the gripper toggles, the takeover button
        toggles who drives (`on_takeover`); the first command waits for the operator's `poll`. A device that
        went away ends the episode here."""
        r = self.reader
        with r.lock:
            if r.gone is not None:
                raise HalError(f"{r.path}: {r.what}: the device went away ({r.gone}; unplugged?)", code="hal.teleop")
            presses = r.decoder.take_presses()
        for name in presses:
            if name == GRIPPER:
                self.gripper = 1.0 - self.gripper
            elif name == TAKEOVER:
                if self.on_takeover is not None:
                    self.on_takeover()
            elif self._command is None:
                self._command = Command(name)

    def command(self) -> Command | None:
        """The episode-ending button pressed since the last call, if any (`DeviceOperator.poll`)."""
        self._drain()
        cmd, self._command = self._command, None
        return cmd

    def reset(self, seed: int) -> None:
        self._drain()  # presses between episodes are dropped, the gripper starts open
        self._command = None
        self.gripper = 0.0
        self.ticks = 0

    def take_over(self, action: npt.NDArray[np.float32]) -> None:
        """Start from `action`, the one in effect (an intervention's takeover): the gripper as it had it; the axes
        are where the person holds them."""
        self.gripper = held_gripper(action)

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        self._drain()
        with self.reader.lock:
            m = self.reader.decoder.motion()
        g = self.gains
        action = np.array([m[0] * g.linear, m[1] * g.linear, m[2] * g.linear, 0.0, 0.0, m[3] * g.yaw, self.gripper])
        if self.show is not None and g.status_every and self.ticks % g.status_every == 0:
            self.show(status_lines(observation, eef_line(observation, self.gripper)))
        self.ticks += 1
        return np.clip(action, self.low, self.high).astype(np.float32)

    def close(self) -> None:
        self.reader.close()


def device_teleop(
    request: DeviceRequest, what: str, gains: DeviceGains, open_reader: Callable[[], DeviceReader]
) -> DeviceTeleop:
    """The contract is checked first (a wrong rSkill is a config error, whatever is plugged in), then the device
    is opened (`open_reader`): a missing one is one line (`hal.teleop`) before anything is recorded."""
    limits = eef_limits(request.rskill, request.source, what)
    return DeviceTeleop(open_reader(), limits, gains.scaled(request.gain), request.show)


class DeviceOperator:
    """The run's operator, plus the device's buttons: a button's command ends the episode like a key would."""

    def __init__(self, inner: Operator, teleop: Buttons) -> None:
        self.inner, self.teleop = inner, teleop
        self.interactive = inner.interactive

    def wait_start(self, episode: int, check: Callable[[], None] = no_check) -> Command:
        return self.inner.wait_start(episode, check)

    def poll(self, episode: int, frame: int) -> Command | None:
        cmd = self.teleop.command()
        return cmd if cmd is not None else self.inner.poll(episode, frame)

    def pause(self, seconds: float, check: Callable[[], None] = no_check) -> Command | None:
        """The reset wait: the operator's keys, and the device's buttons, in 0.1 s slices."""

        def either(wait: float) -> Command | None:
            cmd = self.teleop.command()
            return cmd if cmd in PAUSE_ENDS else self.inner.pause(wait, check)

        return sliced_wait(seconds, 0.1, either)

    def at_end(self) -> Command | None:
        return self.inner.at_end()

    def close(self) -> None:
        self.inner.close()
