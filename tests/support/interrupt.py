"""SIGKILL a real CLI command once its hidden staging folder (`formats.staging`) has content, or Ctrl-C it once a
file shows it is under way, and look for what such a run leaves beside its destination."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from openral_data.formats.staging import staging_name


def kill_when_staged(
    args: list[str], out: Path, ready: str, timeout: float = 300.0, nested: bool = False
) -> subprocess.Popen[str]:
    """Run `openral-data ARGS`, poll until its staging folder for `out` holds `ready` (a glob), then SIGKILL it.

    `nested`: the output is staged twice (`episodes delete --in-place` builds the new dataset, itself staged,
    as the staging folder of the input): poll the inner one."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "openral_data.cli", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    staging = staging_name(out).with_name(f".{out.name}.partial-{proc.pid}")
    if nested:
        staging = staging.with_name(f".{staging.name}.partial-{proc.pid}")
    deadline = time.monotonic() + timeout
    while not any(staging.glob(ready)):
        if proc.poll() is not None:
            raise AssertionError(f"the command ended before it was killed: {proc.communicate()}")
        if time.monotonic() > deadline:
            proc.kill()
            raise AssertionError(f"{staging}/{ready} never appeared")
        time.sleep(0.002)
    proc.send_signal(signal.SIGKILL)
    proc.communicate(timeout=60)
    assert proc.returncode == -signal.SIGKILL
    assert staging.is_dir()  # the kill landed mid-way: the partial output is there, under its hidden name
    return proc


def snapshot(root: Path) -> dict[str, bytes | None]:
    """Every path below `root` with its bytes (None for a folder)."""
    return {str(p.relative_to(root)): (None if p.is_dir() else p.read_bytes()) for p in sorted(root.rglob("*"))}


def hidden_leftovers(parent: Path) -> list[str]:
    return sorted(p.name for p in parent.iterdir() if p.name.startswith("."))


def interrupt_when(
    args: list[str], parent: Path, ready: str, *, group: bool, timeout: float = 300.0
) -> tuple[int, str]:
    """Run `openral-data ARGS` in a session of its own, poll until `parent` holds `ready` (a glob; `{pid}` is the
    command's pid), then send SIGINT: to the command only, or (`group`) to its whole process group, as Ctrl-C at
    a terminal does. Returns its exit status and stderr once every process of its group
    is gone (no worker outlives it)."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "openral_data.cli", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    pattern = ready.format(pid=proc.pid)
    deadline = time.monotonic() + timeout
    try:
        while not any(parent.glob(pattern)):
            if proc.poll() is not None:
                raise AssertionError(f"the command ended before it was interrupted: {proc.communicate()}")
            if time.monotonic() > deadline:
                raise AssertionError(f"{parent}/{pattern} never appeared")
            time.sleep(0.002)
        if group:
            os.killpg(proc.pid, signal.SIGINT)
        else:
            proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=120)
        deadline = time.monotonic() + 30
        while _group_alive(proc.pid):
            if time.monotonic() > deadline:
                raise AssertionError("a process of the interrupted command outlived it")
            time.sleep(0.01)
    finally:
        if _group_alive(proc.pid):
            os.killpg(proc.pid, signal.SIGKILL)
    return proc.returncode, err


def _group_alive(pgid: int) -> bool:
    try:
        os.killpg(pgid, 0)
    except ProcessLookupError:
        return False
    return True
