"""A read-only view of a folder, or a disk that fills up, for tests: a read-only bind mount (CI runs as root,
which ignores permission bits, so chmod would prove nothing) or a small tmpfs. Skips the test with the reason
when mounting is impossible here."""

from __future__ import annotations

import os
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest


@contextmanager
def read_only_view(src: Path, at: Path) -> Iterator[Path]:
    """`src`, mounted read-only at `at` (created) for the duration."""
    at.mkdir(parents=True, exist_ok=True)
    try:
        for cmd in (["mount", "--bind", str(src), str(at)], ["mount", "-o", "remount,ro,bind", str(at)]):
            done = subprocess.run(cmd, capture_output=True, text=True, check=False)
            if done.returncode != 0:
                pytest.skip(f"cannot make a read-only bind mount here: {done.stderr.strip()}")
        assert os.statvfs(at).f_flag & os.ST_RDONLY
        yield at
    finally:
        subprocess.run(["umount", str(at)], check=False, capture_output=True)


@contextmanager
def small_disk(at: Path, size: str = "12k") -> Iterator[Path]:
    """A tmpfs of `size` mounted at `at` (created) for the duration: a disk that fills up after a few writes (real
    ENOSPC from the kernel). Skips the test with the reason when mounting is impossible here."""
    at.mkdir(parents=True, exist_ok=True)
    try:
        done = subprocess.run(
            ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(at)],
            capture_output=True,
            text=True,
            check=False,
        )
        if done.returncode != 0:
            pytest.skip(f"cannot mount a small tmpfs here: {done.stderr.strip()}")
        yield at
    finally:
        subprocess.run(["umount", str(at)], check=False, capture_output=True)
