"""SIGKILL a real CLI command once its hidden staging folder (`formats.staging`) has content, and look for what
a killed run leaves beside its destination."""

from __future__ import annotations

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
