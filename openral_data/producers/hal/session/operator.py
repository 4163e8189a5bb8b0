"""Operator controls for HAL recording: start an episode, stop it as success or failure, discard it,
re-record it, quit, or trip the e-stop.

`KeyboardOperator` reads single keys from a terminal (stdin in cbreak mode; no X11, unlike pynput).
`ScriptedOperator` is the non-interactive equivalent for scripts and tests: a list of per-episode verdicts
such as `success@40,discard@10,failure` (verdict @ frame count; no `@`: at the step limit).
"""

from __future__ import annotations

import os
import select
import sys
import termios
import time
import tty
from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum
from typing import Protocol

from openral_data.errors import UsageError


class Command(StrEnum):
    START = "start"
    SUCCESS = "success"
    FAILURE = "failure"
    DISCARD = "discard"
    RERECORD = "rerecord"
    QUIT = "quit"
    ESTOP = "estop"


KEYS: dict[str, Command] = {
    " ": Command.START,
    "\n": Command.START,
    "\r": Command.START,
    "s": Command.SUCCESS,
    "f": Command.FAILURE,
    "d": Command.DISCARD,
    "r": Command.RERECORD,
    "q": Command.QUIT,
    "x": Command.ESTOP,
}
HELP = "keys: space/enter start · s success · f failure · d discard · r re-record · q quit · x e-stop"


def no_check() -> None:
    """The default `check` of a wait: nothing to check (no e-stop source, no device to watch)."""


class Operator(Protocol):
    interactive: bool

    def wait_start(self, episode: int, check: Callable[[], None] = no_check) -> Command:
        """Block until the operator starts episode `episode` (START) or quits (QUIT); `check()` is called
        while waiting (it raises to abandon the wait, e.g. on Ctrl-C)."""
        ...

    def poll(self, episode: int, frame: int) -> Command | None:
        """Non-blocking: a command given during the episode, after `frame` frames were recorded."""
        ...

    def pause(self, seconds: float, check: Callable[[], None] = no_check) -> Command | None:
        """Between episodes (the reset time): wait `seconds` (None), unless the operator starts the next episode
        now (START), quits (QUIT) or trips the e-stop (ESTOP) first; `check()` is called while waiting."""
        ...

    def at_end(self) -> Command | None:
        """The verdict for an episode that ended without a command (step limit or the scene's end), if any."""
        ...

    def close(self) -> None: ...


PAUSE_ENDS = (Command.START, Command.QUIT, Command.ESTOP)  # the commands that end a reset wait early


def sliced_wait(seconds: float, slice_s: float, step: Callable[[float], Command | None]) -> Command | None:
    """A reset wait of `seconds` in slices: `step(slice)` waits at most one slice; the first command it returns
    ends the wait (None: the time ran out)."""
    end = time.monotonic() + seconds
    while (left := end - time.monotonic()) > 0:
        cmd = step(min(slice_s, left))
        if cmd is not None:
            return cmd
    return None


class KeyboardOperator:
    """Single keypresses from a terminal file descriptor (default: stdin).

    With a `listener` (a teleoperation device, producers/hal/teleop/keyboard.py) the keys that are no operator command
    go to it: during an episode every key waiting at a tick is read, commands act, the rest drive the robot.
    """

    interactive = True

    def __init__(self, fd: int | None = None, listener: Callable[[str], None] | None = None) -> None:
        self.fd = sys.stdin.fileno() if fd is None else fd
        if not os.isatty(self.fd):
            raise UsageError("--operator keyboard: stdin is not a terminal (use --operator auto or a script)")
        self.listener = listener
        self._escape = 0  # characters of an escape sequence still to come
        self._saved = termios.tcgetattr(self.fd)
        tty.setcbreak(self.fd)

    def _key(self, timeout: float) -> Command | None:
        ready, _, _ = select.select([self.fd], [], [], timeout)
        if not ready:
            return None
        ch = os.read(self.fd, 1).decode(errors="replace")
        # an escape sequence (ESC [ A..D: the arrow keys) is no command, whatever its letters
        in_escape = bool(self._escape) or ch == "\x1b"
        self._escape = self._escape - 1 if self._escape else 2 if ch == "\x1b" else 0
        cmd = None if in_escape else KEYS.get(ch.lower())
        if cmd is None and self.listener is not None:
            self.listener(ch)
        return cmd

    def wait_start(self, episode: int, check: Callable[[], None] = no_check) -> Command:
        while True:
            check()
            cmd = self._key(0.1)
            if cmd in (Command.START, Command.QUIT):
                return cmd

    def pause(self, seconds: float, check: Callable[[], None] = no_check) -> Command | None:
        def key(wait: float) -> Command | None:
            check()
            cmd = self._key(wait)
            return cmd if cmd in PAUSE_ENDS else None

        return sliced_wait(seconds, 0.1, key)

    def poll(self, episode: int, frame: int) -> Command | None:
        while True:  # every key waiting: a teleoperator types faster than one key per tick
            ready, _, _ = select.select([self.fd], [], [], 0.0)
            if not ready:
                return None
            cmd = self._key(0.0)
            if cmd is not None and cmd is not Command.START:
                return cmd

    def at_end(self) -> Command | None:
        return None

    def close(self) -> None:
        termios.tcsetattr(self.fd, termios.TCSADRAIN, self._saved)


@dataclass(frozen=True)
class Verdict:
    command: Command
    at_frame: int | None  # None: when the episode reaches its step limit (or the scene ends it)


def parse_script(text: str) -> list[Verdict]:
    """`success@40,discard@10,failure,estop@5` -> verdicts, one per started episode, in order."""
    out: list[Verdict] = []
    allowed = {c.value: c for c in Command if c is not Command.START}
    for k, item in enumerate(filter(None, (s.strip() for s in text.split(",")))):
        name, _, at = item.partition("@")
        if name not in allowed:
            raise UsageError(f"--operator: item {k} {item!r}: unknown verdict; valid: {', '.join(allowed)}")
        frame: int | None = None
        if at:
            if not at.isdigit() or int(at) < 1:
                raise UsageError(f"--operator: item {k} {item!r}: @ needs a frame count >= 1")
            frame = int(at)
        out.append(Verdict(allowed[name], frame))
    return out


class ScriptedOperator:
    """Episodes start at once; the k-th started episode ends with the k-th verdict (then: at the step limit).

    A verdict without a frame count (and every episode after the script ran out) ends at the step limit or
    when the scene says the task ended; `success`/`failure` then still set the outcome.
    """

    interactive = False

    def __init__(self, verdicts: list[Verdict] | None = None) -> None:
        self.verdicts = list(verdicts or [])
        self._started = -1

    def wait_start(self, episode: int, check: Callable[[], None] = no_check) -> Command:
        check()
        self._started += 1
        return Command.START

    def current(self) -> Verdict | None:
        return self.verdicts[self._started] if 0 <= self._started < len(self.verdicts) else None

    def poll(self, episode: int, frame: int) -> Command | None:
        v = self.current()
        if v is not None and v.at_frame is not None and frame >= v.at_frame:
            return v.command
        return None

    def pause(self, seconds: float, check: Callable[[], None] = no_check) -> Command | None:
        def nap(wait: float) -> None:
            check()
            time.sleep(wait)

        return sliced_wait(seconds, 0.05, nap)

    def at_end(self) -> Command | None:
        planned = self.current()
        return planned.command if planned is not None and planned.at_frame is None else None

    def close(self) -> None:
        pass
