"""The real `openral-data` entry point in a subprocess whose time and memory are bounded, for inputs that could
hang a reader or make it allocate without end (a FIFO, /dev/zero, a decompression bomb): a regression fails the
test instead of hanging CI or exhausting the machine."""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
from dataclasses import dataclass
from subprocess import PIPE

MEMORY = 3 << 30  # far above what any command needs on a small dataset, far below a bomb


@dataclass(frozen=True)
class Bounded:
    returncode: int
    stdout: str
    stderr: str
    timed_out: bool


def run_bounded(*args: str, timeout: float = 60) -> Bounded:
    """`openral-data ARGS` in its own process group (killed whole after `timeout` s) with at most `MEMORY` of
    data."""
    cli = [sys.executable, "-m", "openral_data.cli", *args]
    proc = subprocess.Popen(cli, stdout=PIPE, stderr=PIPE, text=True, start_new_session=True)  # a group to kill
    resource.prlimit(proc.pid, resource.RLIMIT_DATA, (MEMORY, MEMORY))  # before its imports are done
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, err = proc.communicate()
        return Bounded(proc.returncode, out, err, True)
    return Bounded(proc.returncode, out, err, False)
