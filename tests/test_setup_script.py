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


def test_each_step_says_what_and_how_long(tmp_path: Path) -> None:
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
        [str(bin_dir / "bash"), "scripts/setup.sh"], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=60,
        check=False,
    )  # fmt: skip
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
