"""`scripts/setup.sh` talks: each step says what it does and about how long it takes before it starts, then how
long it took, and the end says how long it all took. Run on a copy of the script with stand-ins for Python, uv,
dpkg and apt (nothing installed), on a machine missing everything: every step runs."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

from tests.support.home import REPO

PYTHON = """#!/bin/sh
case "$1" in
  -c) exit 0 ;;  # the Python 3.12 check
  --version) echo "Python 3.12.1" ;;
  -m) shift; echo "$*" >> "$(dirname "$0")/calls"
      while [ $# -gt 0 ]; do [ "$1" = --target ] && mkdir -p "$2"; shift; done ;;
esac
"""
APT = """#!/bin/sh
echo "apt-get $*" >> "$(dirname "$0")/calls"
"""


def _run_setup(tmp_path: Path, *args: str) -> tuple[subprocess.CompletedProcess[str], Path]:
    """A copy of setup.sh run with the stand-ins on a machine missing everything; its result and the stand-ins'
    folder (whose `calls` lists what they were asked)."""
    (tmp_path / "scripts").mkdir()
    shutil.copy(REPO / "scripts" / "setup.sh", tmp_path / "scripts" / "setup.sh")
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    stubs = {"python": PYTHON, "apt-get": APT, "sudo": '#!/bin/sh\nexec "$@"\n', "dpkg-query": "#!/bin/sh\n"}
    for name, text in stubs.items():
        (bin_dir / name).write_text(text)
        (bin_dir / name).chmod(0o755)
    tools = {t: shutil.which(t) for t in ("bash", "dirname", "grep", "id", "rm", "touch", "mkdir", "cat")}
    for tool, path in tools.items():
        assert path is not None, tool
        (bin_dir / tool).symlink_to(path)
    env = {"PATH": str(bin_dir), "HOME": str(tmp_path)}  # no pyenv, no uv: both steps that install them run
    done = subprocess.run(
        [str(bin_dir / "bash"), "scripts/setup.sh", *args], cwd=tmp_path, env=env, capture_output=True, text=True,
        timeout=60, check=False,
    )  # fmt: skip
    return done, bin_dir


def test_each_step_says_what_and_how_long(tmp_path: Path) -> None:
    done, bin_dir = _run_setup(tmp_path)
    assert done.returncode == 0, done.stderr
    lines = done.stderr.splitlines()
    starts = [i for i, line in enumerate(lines) if line.endswith(" ...")]
    assert len(starts) == 5, lines  # apt, uv, the locked sync, two old lerobot releases
    for i in starts:
        assert re.fullmatch(r"setup: \S.* \((about|seconds)[^)]*\) \.\.\.", lines[i]), lines[i]  # what, about how long
        assert re.fullmatch(r"setup:   done in \d+ s", lines[i + 1]), lines[i + 1]  # how long it took
    assert re.fullmatch(r"setup: ready in \d+ s: \.venv/bin/openral-data", lines[-1]), lines[-1]
    calls = (bin_dir / "calls").read_text()
    assert "apt-get install" in calls and "uv sync --frozen" in calls and "pip install --quiet" in calls
    assert os.path.isfile(tmp_path / ".old-lerobot" / "0.3.3" / ".installed")


def test_core_installs_the_core_only(tmp_path: Path) -> None:
    """`setup.sh --core` (scripts/demo.sh's): the locked core without the dev group or any extra, added to .venv
    without removing anything; no old lerobot releases; the rendering packages but not the browser or libusb."""
    done, bin_dir = _run_setup(tmp_path, "--core")
    assert done.returncode == 0, done.stderr
    calls = (bin_dir / "calls").read_text().splitlines()
    (sync,) = [c for c in calls if c.startswith("uv sync")]
    assert {"--frozen", "--no-dev", "--inexact"} <= set(sync.split()) and "--extra" not in sync
    assert not [c for c in calls if "--no-deps" in c] and not (tmp_path / ".old-lerobot").exists()  # no old lerobot
    (apt,) = [c for c in calls if c.startswith("apt-get install")]
    assert "libegl1" in apt and "chromium" not in apt and "libusb-1.0-0" not in apt
    assert done.stderr.splitlines()[-1].startswith("setup: ready in ")
