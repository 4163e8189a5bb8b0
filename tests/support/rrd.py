"""Rerun recordings: `rerun rrd verify` from the environment's own rerun binary."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

RERUN = Path(sys.executable).with_name("rerun")


def verify(rrd: Path) -> None:
    proc = subprocess.run([str(RERUN), "rrd", "verify", str(rrd)], capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stdout + proc.stderr
