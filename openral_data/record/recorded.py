"""`record --resume`: which scene and rSkill a recording's `.openral/record.json` may bring back.

`record.json` lies inside the dataset, so it is untrusted (docs/threat-model.md): it could name any file, and
its own `scene_sha256` could vouch for any file whose bytes an attacker knows. A reference taken from it is used
only as a manifest on the search path (`openral_data.manifests`): its id, or the exact resolved file of one (what
recordings store). Any other scene or rSkill (a path given with `--scene PATH` / `--rskill PATH` when recording)
is refused; the user names it again with `--scene` / `--rskill`. A scene so named must still have the sha256 the
recording stored (`unchanged`): that guards the user against continuing a dataset with an edited scene. These
checks run before anything is built or loaded.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from openral_data import manifests
from openral_data.errors import ConfigError
from openral_data.paths import read_regular

MAX_MANIFEST_BYTES = 4 << 20  # a scene or rSkill manifest is a few KB; more is not one
KINDS: dict[str, manifests.Kind] = {"scene": "scenes", "rskill": "rskills"}  # record.json's manifest references


def sha256(path: Path) -> str:
    """The sha256 of a manifest file's bytes (a regular file of at most `MAX_MANIFEST_BYTES`)."""
    try:
        data = read_regular(path, MAX_MANIFEST_BYTES)
    except ValueError as exc:
        raise ConfigError(f"{path}: {exc}; not a manifest") from None
    return hashlib.sha256(data).hexdigest()


def on_search_path(name: str, value: str) -> Path | None:
    """The manifest file the recorded `name` (`scene` or `rskill`) `value` names when it is an id on the search
    path or the resolved file of one."""
    found = manifests.entries(KINDS[name])
    if value in found:
        return found[value].path
    for entry in found.values():
        if value in (str(entry.path), str(entry.path.resolve())):
            return entry.path
    return None


def trusted(name: str, value: object, source: Path, flag: str | None = None) -> str:
    """The reference `record --resume` may use for the recorded `name` (`scene` or `rskill`) `value`: the
    search-path manifest it names. `source` is record.json (named in the refusal), `flag` the option that names
    it again (default `--NAME`)."""
    flag = flag or f"--{name}"
    if not isinstance(value, str) or not value:
        raise ConfigError(f"{source}: {name}: not recorded; name it again with {flag}")
    path = on_search_path(name, value)
    if path is not None:
        return str(path)
    why = (
        "a scene chooses the simulator and assets we load"
        if name == "scene"
        else "an rSkill chooses the policy code we load"
    )
    raise ConfigError(
        f"{source}: {name}: {value!r} is not on the manifest search path ({why}); name it again with {flag} to continue"
    )


def unchanged(scene: str, digest: object, source: Path) -> None:
    """The scene named again with `--scene` still has the sha256 `digest` the recording stored, if it stored one
    (recordings before `scene_sha256` did not). `source` is record.json."""
    if not isinstance(digest, str):
        return
    from openral_data.runtime.registry import resolve_scene_path

    path = resolve_scene_path(scene)
    try:
        now = sha256(path)
    except OSError as exc:
        raise ConfigError(f"{path}: {exc.strerror or exc}") from None
    if now != digest:
        raise ConfigError(
            f"{source}: scene: {scene!r} changed since the recording (sha256 differs); a dataset continues with "
            "the scene it was recorded with"
        )


def same(name: str, given: str, stored: object) -> bool:
    """Whether the reference given again on the command line is the recorded one, compared by the file each
    resolves to; the recorded one only through the search path or as the string it is (never opened)."""
    from openral_data.runtime.registry import resolve_rskill, resolve_scene_path

    now = resolve_scene_path(given) if name == "scene" else resolve_rskill(given)[1]
    if not isinstance(stored, str):
        return False
    found = on_search_path(name, stored)
    return str(now.resolve()) == (str(found.resolve()) if found is not None else stored)
