"""Helpers shared by adapters over external simulators (gym-aloha, gym-pusht, LIBERO): optional imports,
the simulator's own cameras and its fixed control rate."""

from __future__ import annotations

import importlib
from collections.abc import Sequence
from types import ModuleType

from openral_data.errors import ConfigError, install_hint
from openral_data.schemas.scene import SceneCamera, SimScene


def require(module: str, extra: str, source: str, install: str | None = None) -> ModuleType:
    """Import an optional simulator package; a missing one is a one-line error naming the extra to install."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        how = install or install_hint(extra)
        raise ConfigError(
            f"{source}: scene.type: needs the {extra!r} extra ({exc.name or module} missing): {how}"
        ) from None


def named_cameras(
    scene: SimScene, available: Sequence[str], source: str, *, max_count: int | None = None
) -> list[SceneCamera]:
    """The YAML's cameras, each one the simulator defines by name (it places them; `pos`/`lookat`/`mount` are
    refused so nobody believes they moved a camera)."""
    cams = list(scene.scene.cameras)
    check_cameras(cams, available, source)
    if max_count is not None and len(cams) > max_count:
        raise ConfigError(
            f"{source}: scene.cameras: this simulator renders at most {max_count} view(s), got {len(cams)}"
        )
    return cams


def check_cameras(
    cameras: Sequence[SceneCamera],
    available: Sequence[str],
    source: str,
    unknown: str = "{where}.name: {name!r} is not a camera of this simulator; valid: {valid}",
    placed: str = "{where}: {name!r} is placed by the simulator; remove pos/lookat/mount",
) -> None:
    """Each camera must be one of `available` and carry no placement; the refusals are the `unknown` / `placed`
    templates (fields `where`, `name`, `valid`)."""
    valid = ", ".join(available)
    for i, cam in enumerate(cameras):
        where = f"{source}: scene.cameras[{i}]"
        if cam.name not in available:
            raise ConfigError(unknown.format(where=where, name=cam.name, valid=valid))
        if cam.pos is not None or cam.lookat is not None or cam.mount != "world":
            raise ConfigError(placed.format(where=where, name=cam.name, valid=valid))


def check_fps(scene: SimScene, fps: int, source: str) -> None:
    if scene.scene.fps != fps:
        raise ConfigError(
            f"{source}: scene.fps: this simulator steps at {fps} Hz (control rate), got {scene.scene.fps}"
        )
