"""The `uv` executable: on PATH, or beside the interpreter `.venv` was made from (scripts/setup.sh installs it
there with pip when PATH has none)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest


def uv() -> str:
    """uv's path; the test fails (never skips) when there is none, since scripts/setup.sh always installs it."""
    beside = Path(sys.base_prefix) / "bin" / "uv"
    found = shutil.which("uv") or (str(beside) if beside.is_file() else None)
    if found is None or subprocess.run([found, "--version"], capture_output=True, check=False, timeout=60).returncode:
        pytest.fail("uv is neither on PATH nor beside the base interpreter (scripts/setup.sh installs it)")
    return found
