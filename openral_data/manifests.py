"""Where scene, rSkill and robot manifests are found, and where outputs go.

Manifests are looked up along a search path, lowest precedence first:

1. ``built-in``: the manifests shipped inside the package (``openral_data/builtin/``, read as package data);
2. ``plug-in <dist>``: folders that installed plug-ins name through the ``openral_data.manifests`` (a folder
   with ``scenes/``, ``rskills/``, ``robots/``) and ``openral_data.robots`` (a folder of robots) entry points;
3. ``user``: the user's config home, ``$OPENRAL_DATA_CONFIG`` or ``$XDG_CONFIG_HOME/openral-data`` (default
   ``~/.config/openral-data``);
4. ``project``: the project directory, ``$OPENRAL_DATA_HOME`` or else the current directory;
5. ``$OPENRAL_SCENES_DIR`` / ``$OPENRAL_RSKILLS_DIR`` / ``$OPENRAL_ROBOTS_DIR`` (what ``--scenes-dir``,
   ``--rskills-dir`` and ``--robots-dir`` set; ``os.pathsep``-separated, later folders win).

A manifest with an id an earlier layer also has overrides it (`Entry.overrides` names what it hides). Outputs
default to ``<project>/datasets`` (`datasets_dir`).

Layout inside a layer: ``scenes/*.yaml`` and ``scenes/{sim,benchmark,deploy}/*.yaml`` (a scene's id is its file
stem), ``rskills/<id>/rskill.yaml``, ``robots/<id>/robot.yaml``. Entry-point problems (a plug-in that fails to
import, or names no folder) never break the rest; they are collected by `plugin_problems`.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Literal

from openral_data.errors import ConfigError

if TYPE_CHECKING:
    import importlib.metadata

__all__ = [
    "DEFAULT_SCENE",
    "ENV_DIRS",
    "KINDS",
    "SCENE_TIERS",
    "Entry",
    "Kind",
    "PluginProblem",
    "builtin_dir",
    "cache_home",
    "config_home",
    "datasets_dir",
    "entries",
    "find",
    "ids",
    "layers",
    "one_line",
    "plugin_objects",
    "plugin_problems",
    "project_dir",
    "record_problem",
    "results_dir",
    "robot_file",
]

Kind = Literal["scenes", "rskills", "robots"]
KINDS: tuple[Kind, ...] = ("scenes", "rskills", "robots")
SCENE_TIERS = ("sim", "benchmark", "deploy")
ENV_DIRS: dict[Kind, str] = {
    "scenes": "OPENRAL_SCENES_DIR",
    "rskills": "OPENRAL_RSKILLS_DIR",
    "robots": "OPENRAL_ROBOTS_DIR",
}
DEFAULT_SCENE = "mock_pick"
_FILE: dict[Kind, str] = {"rskills": "rskill.yaml", "robots": "robot.yaml"}


@dataclass(frozen=True)
class Entry:
    """One manifest: its id, file, the layer it comes from and the layers it hides (lowest first)."""

    kind: Kind
    id: str
    path: Path
    origin: str
    overrides: tuple[str, ...] = ()


@dataclass(frozen=True)
class PluginProblem:
    """An entry point that could not be used: `group`, its `name`, the `dist` that declares it, and why."""

    group: str
    name: str
    dist: str
    error: str

    def line(self) -> str:
        return f"plug-in {self.name!r} ({self.group}, from {self.dist}): {self.error}"


_PROBLEMS: dict[tuple[str, str, str], PluginProblem] = {}


def record_problem(problem: PluginProblem) -> None:
    """Remember a broken plug-in (once); `list` and `doctor` report them."""
    _PROBLEMS.setdefault((problem.group, problem.name, problem.dist), problem)


def plugin_problems() -> list[PluginProblem]:
    """Every broken plug-in met so far in this process (load the registries first to meet them all)."""
    for kind in KINDS:
        _plugin_layers(kind)
    return list(_PROBLEMS.values())


def builtin_dir() -> Path:
    """The package's own manifests (package data; an installed wheel is always unpacked on disk)."""
    import importlib.resources  # here: with tempfile, ~10 ms that `--version` and `info` need not pay

    return Path(str(importlib.resources.files("openral_data") / "builtin"))


def config_home() -> Path:
    env = os.environ.get("OPENRAL_DATA_CONFIG")
    if env:
        return Path(env).expanduser()
    base = os.environ.get("XDG_CONFIG_HOME") or str(Path("~/.config").expanduser())
    return Path(base) / "openral-data"


def cache_home() -> Path:
    """Where openral-data keeps what it can compute again: `$XDG_CACHE_HOME/openral-data` (default
    `~/.cache/openral-data`)."""
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "openral-data"


def project_dir() -> Path:
    """`$OPENRAL_DATA_HOME` if set, else the current directory."""
    env = os.environ.get("OPENRAL_DATA_HOME")
    return Path(env).expanduser().resolve() if env else Path.cwd()


def datasets_dir() -> Path:
    """Where outputs go when no `--out` is given: `<project>/datasets`."""
    return project_dir() / "datasets"


def results_dir() -> Path:
    """Where `replay` puts its results when no `--out` is given: `<project>/results`."""
    return project_dir() / "results"


def layers(kind: Kind) -> list[tuple[str, Path]]:
    """The `(origin, folder)` pairs searched for `kind`, lowest precedence first (folders may not exist)."""
    out = [("built-in", builtin_dir() / kind)]
    out += _plugin_layers(kind)
    out += [("user", config_home() / kind), ("project", project_dir() / kind)]
    env = os.environ.get(ENV_DIRS[kind], "")
    out += [(f"${ENV_DIRS[kind]}", Path(p).expanduser()) for p in env.split(os.pathsep) if p]
    return out


def entries(kind: Kind) -> dict[str, Entry]:
    """Every manifest of `kind` by id, the highest layer winning, sorted by id."""
    found: dict[str, Entry] = {}
    for origin, folder in layers(kind):
        for ident, path in _scan(kind, folder).items():
            hidden = found.get(ident)
            overrides = (*hidden.overrides, hidden.origin) if hidden else ()
            found[ident] = Entry(kind, ident, path, origin, overrides)
    return dict(sorted(found.items()))


def ids(kind: Kind) -> list[str]:
    return list(entries(kind))


def find(kind: Kind, ident: str) -> Path | None:
    """The manifest file `ident` of `kind` resolves to, or None."""
    entry = entries(kind).get(ident)
    return entry.path if entry else None


def robot_file(robot_id: str) -> Path:
    """`robots/<id>/robot.yaml` of a robot on the search path (its folder anchors relative asset paths)."""
    path = find("robots", robot_id)
    if path is None:
        raise ConfigError(f"robot {robot_id!r}: no robots/{robot_id}/robot.yaml on the manifest search path")
    return path


def _scan(kind: Kind, folder: Path) -> dict[str, Path]:
    if not folder.is_dir():
        return {}
    if kind == "scenes":
        out: dict[str, Path] = {}
        for sub in (*SCENE_TIERS, "."):
            tier = folder / sub
            for p in sorted(tier.glob("*.yaml")) if tier.is_dir() else []:
                out.setdefault(p.stem, p)
        return out
    name = _FILE[kind]
    return {p.parent.name: p for p in sorted(folder.glob(f"*/{name}"))}


# --- plug-ins ---------------------------------------------------------------------------------------------

_GROUPS: dict[str, Callable[[Kind, Path], Path | None]] = {
    # a folder holding scenes/ rskills/ robots/
    "openral_data.manifests": lambda kind, root: root / kind,
    # a folder of robots/<id>/robot.yaml
    "openral_data.robots": lambda kind, root: root if kind == "robots" else None,
}


def _plugin_layers(kind: Kind) -> list[tuple[str, Path]]:
    out: list[tuple[str, Path]] = []
    for group, pick in _GROUPS.items():
        for dist, root in _plugin_folders(group):
            folder = pick(kind, root)
            if folder is not None:
                out.append((f"plug-in {dist}", folder))
    return out


_LOADED: dict[str, list[tuple[str, str, object]]] = {}


def plugin_objects(group: str) -> list[tuple[str, str, object]]:
    """`(name, dist, object)` for each entry point of `group` that loads (imported once per process); one that
    fails to import is recorded as a `PluginProblem` and left out."""
    if group not in _LOADED:
        out: list[tuple[str, str, object]] = []
        for ep in _entry_points().select(group=group):
            dist = ep.dist.name if ep.dist is not None else "?"
            try:
                out.append((ep.name, dist, ep.load()))
            except KeyboardInterrupt:
                raise
            except BaseException as exc:  # noqa: BLE001 - a plug-in's failure (`sys.exit` too) must not break us
                record_problem(PluginProblem(group, ep.name, dist, one_line(exc)))
        _LOADED[group] = out
    return _LOADED[group]


@functools.cache
def _entry_points() -> importlib.metadata.EntryPoints:
    """Every installed entry point, read once (reading them walks every installed distribution: ~20 ms here)."""
    import importlib.metadata  # here: it takes ~15 ms, which `--version` and `info` need not pay

    return importlib.metadata.entry_points()


def _plugin_folders(group: str) -> list[tuple[str, Path]]:
    out: list[tuple[str, Path]] = []
    for name, dist, obj in plugin_objects(group):
        try:
            out.append((dist, _folder_of(obj)))
        except ValueError as exc:
            record_problem(PluginProblem(group, name, dist, str(exc)))
    return out


def _folder_of(obj: object) -> Path:
    if isinstance(obj, ModuleType):
        files = obj.__spec__.submodule_search_locations if obj.__spec__ else None
        if not files:
            raise ValueError(f"module {obj.__name__!r} is not a package (it has no folder)")
        path = Path(next(iter(files)))
    elif isinstance(obj, (str, os.PathLike)):
        path = Path(obj)
    else:
        raise ValueError(f"names a {type(obj).__name__}, not a package or a folder")
    if not path.is_dir():
        raise ValueError(f"{path} is not a folder")
    return path


def one_line(exc: BaseException) -> str:
    """`Type: message` on one line, for a plug-in's error."""
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__
