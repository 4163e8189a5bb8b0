"""The far side of a pseudo-terminal a CLI subprocess runs on: what the program printed, and keys typed into it
(a person at the terminal, for the keyboard operator and teleop tests)."""

from __future__ import annotations

import contextlib
import os
import re
import select
import subprocess
import sys
import time
from collections.abc import Iterator


class Terminal:
    def __init__(self, master: int) -> None:
        self.master = master
        self.text = b""

    def read(self, timeout: float) -> None:
        ready, _, _ = select.select([self.master], [], [], timeout)
        if ready:
            with contextlib.suppress(OSError):  # the program exited and closed the pty
                self.text += os.read(self.master, 65536)

    def wait_for(self, pattern: bytes, timeout: float, after: int = 0) -> tuple[float, int]:
        """When (monotonic) `pattern` was seen after byte `after`, and the byte after it."""
        end = time.monotonic() + timeout
        while (at := self.text.find(pattern, after)) < 0:
            assert time.monotonic() < end, self.text[-2000:].decode(errors="replace")
            self.read(0.05)
        return time.monotonic(), at + len(pattern)

    def search(self, pattern: re.Pattern[bytes], after: int, timeout: float) -> re.Match[bytes]:
        """The first match of `pattern` after byte `after`, waiting for it up to `timeout` s."""
        end = time.monotonic() + timeout
        while (found := pattern.search(self.text, after)) is None:
            assert time.monotonic() < end, self.text[-2000:].decode(errors="replace")
            self.read(0.05)
        return found

    def type(self, keys: str) -> None:
        os.write(self.master, keys.encode())


@contextlib.contextmanager
def cli_on_pty[T: Terminal](args: list[str], terminal: type[T]) -> Iterator[tuple[subprocess.Popen[bytes], T]]:
    """`openral-data ARGS` in a subprocess whose stdin, stdout and stderr are a pty (MUJOCO_GL=egl), and the
    terminal on its far side; the program is killed if it still runs at the end."""
    master, slave = os.openpty()
    proc = subprocess.Popen(
        [sys.executable, "-m", "openral_data.cli", *args],
        stdin=slave, stdout=slave, stderr=slave, env={**os.environ, "MUJOCO_GL": "egl"}, close_fds=True,
    )  # fmt: skip
    os.close(slave)
    try:
        yield proc, terminal(master)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        os.close(master)
