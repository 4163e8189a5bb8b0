"""Rerun recordings: `rerun rrd verify` from the environment's own rerun binary.

`RERUN` is the binary rerun-sdk ships (`rerun_cli/rerun`), not the `rerun` console script: that script is a Python
wrapper whose child does not get a signal sent to the wrapper (on Ctrl-C the wrapper SIGKILLs it), so tests that
stop a saving rerun must signal the binary itself."""

from __future__ import annotations

import subprocess
from pathlib import Path

import rerun_cli

RERUN = Path(rerun_cli.__file__).parent / "rerun"


def verify(rrd: Path) -> None:
    proc = subprocess.run([str(RERUN), "rrd", "verify", str(rrd)], capture_output=True, text=True, check=False)
    assert proc.returncode == 0, proc.stdout + proc.stderr
