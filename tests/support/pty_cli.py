"""The real CLI on a pseudo-terminal, as a person at a terminal uses it: `on_pty` runs it as a subprocess whose
stdin, stdout and stderr are the pty; `Terminal` is the far side (what it printed, keys typed into it)."""

from __future__ import annotations

import contextlib
import os
import select
import subprocess
import sys
import time
from collections.abc import Iterator


class Terminal:
    """The far side of the pty: what the program printed, and keys typed into it."""

    def __init__(self, master: int) -> None:
        self.master = master
        self.text = b""

    def read(self, timeout: float) -> None:
        ready, _, _ = select.select([self.master], [], [], timeout)
        if ready:
            with contextlib.suppress(OSError):  # the program exited and closed the pty
                self.text += os.read(self.master, 65536)

    def wait_for(self, pattern: bytes, timeout: float) -> None:
        end = time.monotonic() + timeout
        while pattern not in self.text:
            assert time.monotonic() < end, self.text[-2000:].decode(errors="replace")
            self.read(0.1)

    def type(self, keys: str) -> None:
        os.write(self.master, keys.encode())


@contextlib.contextmanager
def on_pty(*args: str) -> Iterator[tuple[subprocess.Popen[bytes], Terminal]]:
    """`openral-data ARGS` on a fresh pty (MUJOCO_GL=egl); killed if still running when the block ends."""
    master, slave = os.openpty()
    proc = subprocess.Popen(
        [sys.executable, "-m", "openral_data.cli", *args],
        stdin=slave, stdout=slave, stderr=slave, env={**os.environ, "MUJOCO_GL": "egl"}, close_fds=True,
    )  # fmt: skip
    os.close(slave)
    try:
        yield proc, Terminal(master)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        os.close(master)
