"""Faults that used to end in a traceback (#29, class 7): a Ctrl-C while the command line is still importing its
modules, a full disk while taking the writer lock, EIO on the last fsync of a publish, and a `--plot` / `--save`
into a read-only folder. Each is one `error:` line and exit 2 (Ctrl-C: exit 130), nothing written lost."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

ENTRY_POINTS = {
    "python -m": [sys.executable, "-m", "openral_data.cli"],
    "console script": [str(Path(sys.executable).with_name("openral-data"))],
}


@pytest.mark.parametrize("entry", list(ENTRY_POINTS), ids=list(ENTRY_POINTS))
def test_ctrl_c_while_importing_exits_130_without_traceback(entry: str, tmp_path: Path) -> None:
    """SIGINT right after `typer` is imported, while the command modules are still loading (`-X importtime`
    reports each finished import on stderr, so the signal lands inside the import window, not by timing)."""
    cmd = ENTRY_POINTS[entry]
    if not Path(cmd[0]).exists():
        pytest.skip(f"{cmd[0]} is not installed")
    env = {**os.environ, "PYTHONPROFILEIMPORTTIME": "1"}
    proc = subprocess.Popen(
        [*cmd, "info", str(tmp_path / "missing")], stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env, text=True
    )
    assert proc.stderr is not None
    seen: list[str] = []
    for line in proc.stderr:
        seen.append(line)
        if line.split("|")[-1].strip() == "typer":
            proc.send_signal(signal.SIGINT)
            break
    _, rest = proc.communicate(timeout=60)
    stderr = "".join(seen) + rest
    assert "Traceback" not in stderr, stderr[-2000:]
    assert proc.returncode == 130, stderr[-3000:]
