"""A normal install, made once per test session: the wheel built from pyproject.toml with the lock's core
dependencies (no dev group, no extras, so no lerobot and no torch) in a fresh virtual environment outside the
repository. From uv's cache when it has every package (`--offline`; scripts/setup.sh filled it), else from the
registry. tests/test_install.py and tests/test_lean_install.py both use it (the `core_venv` fixture)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from tests.support.home import REPO
from tests.support.uv import uv


def build_core_venv(base: Path) -> Path:
    """`base/venv` holding the wheel (built into `base/dist`) and the core dependencies pinned by uv.lock."""
    env = {k: v for k, v in os.environ.items() if k not in ("VIRTUAL_ENV", "UV_COMPILE_BYTECODE", "PYTHONPATH")}
    env["UV_PYTHON_DOWNLOADS"] = "never"

    def run(*args: str) -> None:
        subprocess.run([uv(), *args], cwd=REPO, env=env, check=True, timeout=1200)

    run("build", "--wheel", "--quiet", "--out-dir", str(base / "dist"))
    run("export", "--frozen", "--no-dev", "--no-emit-project", "--no-hashes", "--quiet", "-o", str(base / "req.txt"))
    python = Path(sys.base_prefix) / "bin" / "python3.12"
    run("venv", "--quiet", "--python", str(python), str(base / "venv"))
    (wheel,) = (base / "dist").glob("openral_data-*.whl")
    install = ("pip", "install", "--quiet", "--python", str(base / "venv/bin/python"), "-r", str(base / "req.txt"))
    try:
        run(*install, "--offline", str(wheel))
    except subprocess.CalledProcessError:  # something not in the cache: fetch it
        run(*install, str(wheel))
    return base / "venv"


def run_installed(venv: Path, cwd: Path, *args: str) -> subprocess.CompletedProcess[str]:
    """`openral-data ARGS` of `venv`, run in `cwd` as a user would: no checkout on the path, no project home,
    no user manifests."""
    drop = ("PYTHONPATH", "OPENRAL_DATA_HOME", "VIRTUAL_ENV", "OPENRAL_SCENES_DIR", "OPENRAL_RSKILLS_DIR")
    env = {k: v for k, v in os.environ.items() if k not in (*drop, "OPENRAL_ROBOTS_DIR", "OPENRAL_DATA_CONFIG")}
    env["XDG_CONFIG_HOME"] = str(cwd / "config")  # no user manifests either
    for display in ("DISPLAY", "WAYLAND_DISPLAY"):  # `view` saves an .rrd instead of opening a viewer
        env.pop(display, None)
    env.setdefault("MUJOCO_GL", "egl")
    return subprocess.run(
        [str(venv / "bin/openral-data"), *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
        check=False,
    )


def site_packages(venv: Path) -> Path:
    return next((venv / "lib").glob("python3.12/site-packages"))


def venv_bytes(venv: Path) -> int:
    """The bytes of every regular file under `venv` (what `du --apparent-size` counts)."""
    return sum(p.stat().st_size for p in venv.rglob("*") if p.is_file() and not p.is_symlink())
