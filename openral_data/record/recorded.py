"""`record --resume`: which scene and rSkill a recording's `.openral/record.json` may bring back.

`record.json` lies inside the dataset, so it is untrusted (docs/threat-model.md): it could name any file, and an
rSkill names the policy code and the checkpoint we load. A reference taken from it is used only as a manifest on
the search path (`openral_data.manifests`): its id, or the exact resolved file of one (what recordings store).
An rSkill anywhere else is refused; the user names it again with `--rskill`. A scene is data (its type and robot
are registry ids, its rSkill is the recorded one), so a scene file elsewhere (`--scene PATH`) is used again only
when it lies outside the dataset and its bytes still have the sha256 the recording stored (`scene_sha256`);
otherwise the user names it again with `--scene`. These checks run before anything is built or loaded.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from openral_data import manifests
from openral_data.errors import ConfigError
from openral_data.paths import regular_file

MAX_MANIFEST_BYTES = 4 << 20  # a scene or rSkill manifest is a few KB; more is not one


def sha256(path: Path) -> str:
    """The sha256 of a manifest file's bytes (a regular file of at most `MAX_MANIFEST_BYTES`)."""
    with regular_file(path).open("rb") as f:
        data = f.read(MAX_MANIFEST_BYTES + 1)
    if len(data) > MAX_MANIFEST_BYTES:
        raise ConfigError(f"{path}: larger than {MAX_MANIFEST_BYTES} bytes; not a manifest")
    return hashlib.sha256(data).hexdigest()


def on_search_path(kind: manifests.Kind, value: str) -> Path | None:
    """The manifest file `value` names when it is an id on the search path or the resolved file of one."""
    found = manifests.entries(kind)
    if value in found:
        return found[value].path
    for entry in found.values():
        if value in (str(entry.path), str(entry.path.resolve())):
            return entry.path
    return None


def trusted(name: str, value: object, digest: object, out: Path, source: Path) -> str:
    """The reference `record --resume` may use for the recorded `name` (`scene` or `rskill`) `value`.

    `source` is record.json (named in the refusal), `out` the dataset (a recorded scene inside it is refused).
    """
    flag = f"--{name}"
    if not isinstance(value, str) or not value:
        raise ConfigError(f"{source}: {name}: not recorded; name it again with {flag}")
    kind: manifests.Kind = "scenes" if name == "scene" else "rskills"
    path = on_search_path(kind, value)
    if path is not None:
        return str(path)
    again = f"name it again with {flag} to continue"
    why = None
    if name != "scene":
        why = "an rSkill chooses the policy code we load"
    elif not isinstance(digest, str):
        why = "no digest of it was recorded"
    elif not Path(value).is_absolute():
        why = "a relative path"
    if why is not None:
        raise ConfigError(f"{source}: {name}: {value!r} is not on the manifest search path ({why}); {again}")
    scene = Path(value)
    if scene.resolve().is_relative_to(out.resolve()):
        raise ConfigError(f"{source}: {name}: {value!r} lies inside the dataset; {again}")
    try:
        now = sha256(scene)
    except OSError as exc:
        raise ConfigError(f"{source}: {name}: {value!r}: {exc.strerror or exc}; {again}") from None
    if now != digest:
        raise ConfigError(f"{source}: {name}: {value!r} changed since the recording (sha256 differs); {again}")
    return value


def same(name: str, given: str, stored: object) -> bool:
    """Whether the reference given again on the command line is the recorded one, compared by the file each
    resolves to; the recorded one only through the search path or as the string it is (never opened)."""
    from openral_data.runtime.registry import resolve_rskill, resolve_scene_path

    now = resolve_scene_path(given) if name == "scene" else resolve_rskill(given)[1]
    if not isinstance(stored, str):
        return False
    kind: manifests.Kind = "scenes" if name == "scene" else "rskills"
    found = on_search_path(kind, stored)
    return str(now.resolve()) == (str(found.resolve()) if found is not None else stored)
