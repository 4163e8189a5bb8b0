"""Resolve asset references of manifests: `pkg://<python package>/<path>` (a file inside that package: a path
leading out of it is refused, DatasetError `dataset.unsafe`), `share://<path>` (a file a wheel installed as data
under the environment's `share/` folder, `sysconfig`'s `data` path: openarm-mujoco ships its MJCF and meshes
there, not inside its package) or a path relative to the manifest.

A package is located with `importlib.util.find_spec` without importing it (robosuite's wheel only lends its
MJCF and mesh files; importing it would pull in its controllers and print warnings).
"""

from __future__ import annotations

import importlib.metadata
import importlib.util
import sysconfig
from pathlib import Path

from openral_data.errors import ConfigError
from openral_data.paths import contained


def resolve_asset(ref: str, base_dir: Path, source: str) -> Path:
    """The file `ref` names; ConfigError naming `source` (file: field) when it cannot be found."""
    if ref.startswith("pkg://"):
        package, _, rel = ref.removeprefix("pkg://").partition("/")
        spec = importlib.util.find_spec(package) if package else None
        if spec is None or not spec.submodule_search_locations:
            raise ConfigError(f"{source}: python package {package!r} is not installed (needed for {ref})")
        path = contained(Path(next(iter(spec.submodule_search_locations))), rel, f"{source}: {ref}")
    elif ref.startswith("share://"):
        path = contained(Path(sysconfig.get_path("data")) / "share", ref.removeprefix("share://"), f"{source}: {ref}")
    else:
        path = (base_dir / ref).resolve()
    if not path.is_file():
        raise ConfigError(f"{source}: {ref}: no such file ({path})")
    return path


def check_robosuite_assets(source: str) -> None:
    """The native scenes' manifests are tuned for robosuite 1.5's robot MJCFs. robosuite 1.4 (the LIBERO
    environment's) ships different files on which the arms cannot reach the ready pose: say so in one line."""
    try:
        version = importlib.metadata.version("robosuite")
    except importlib.metadata.PackageNotFoundError:
        return  # resolve_asset names the missing package
    major_minor = tuple(int(p) for p in version.split(".")[:2] if p.isdigit())
    if major_minor < (1, 5):
        raise ConfigError(
            f"{source}: assets.mjcf: the native MuJoCo scenes need robosuite 1.5's robot models, this environment "
            f"has robosuite {version} (LIBERO's); run them from the default environment (.venv)"
        )
