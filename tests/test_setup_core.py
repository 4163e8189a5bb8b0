"""`scripts/setup.sh --core` (what scripts/demo.sh installs) asks uv for the core alone, adding to .venv without
removing anything, and only the rendering packages of Debian (plain `setup.sh`, scripts/test.sh's, keeps the
dev tools and every extra). Run for real with stand-ins on PATH for python/uv and dpkg-query that log what they
were asked (nothing is installed)."""

from __future__ import annotations

import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

_PYTHON = """#!/bin/sh
echo "$@" >> "$LOG/python"
case "$1" in --version) echo "Python 3.12.0";; esac
exit 0
"""
_DPKG = """#!/bin/sh
echo "$@" >> "$LOG/dpkg"
printf 'install ok installed'
"""


def _fakes(tmp_path: Path) -> dict[str, str]:
    bin_ = tmp_path / "bin"
    bin_.mkdir()
    for name, body in (("python", _PYTHON), ("uv", "#!/bin/sh\nexit 0\n"), ("dpkg-query", _DPKG)):
        (bin_ / name).write_text(body)
        (bin_ / name).chmod(0o755)
    return {"PATH": f"{bin_}:/usr/bin:/bin", "LOG": str(tmp_path), "HOME": str(tmp_path)}


def test_setup_core_installs_the_core_only(tmp_path: Path) -> None:
    env = _fakes(tmp_path)
    done = subprocess.run(
        ["bash", str(ROOT / "scripts/setup.sh"), "--core"],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    syncs = [line for line in (tmp_path / "python").read_text().splitlines() if line.startswith("-m uv sync")]
    assert len(syncs) == 1 and "--no-dev" in syncs[0].split() and "--inexact" in syncs[0].split()
    assert "--extra" not in syncs[0] and "pip install" not in (tmp_path / "python").read_text()  # no old lerobot
    asked = (tmp_path / "dpkg").read_text()
    assert "libegl1" in asked and "chromium" not in asked
