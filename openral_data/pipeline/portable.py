"""A step's settings as they do not depend on where the pipeline's folder lives.

`schema._anchored` makes a step's file references (scenes, rSkills, a convert step's source and mapping)
absolute paths inside the pipeline file's folder. Hashing those would tie a run's completion markers to the
checkout's location: a campaign started in ``/a/pipelines`` and resumed from a copy in ``/b/pipelines`` would
refuse every finished step. `portable` writes each such path relative to the folder instead and, for the files
that configure a step (a scene, an rSkill, a convert mapping), adds their content's sha256, so editing a
scene file changes the record step's hash while moving the checkout does not. A convert step's source (data,
possibly gigabytes) counts by its relative path only. A manifest id is kept as it is.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

from openral_data.paths import read_regular
from openral_data.pipeline.schema import Step

MAX_HASHED_BYTES = 64 << 20  # a file over this counts by its size (an rSkill folder's checkpoint)
MAX_HASHED_FILES = 10_000  # files of a referenced folder that count; more are left out
CONTENT_FIELDS = {"record": ("scenes", "rskills"), "evaluate": ("scene",), "dagger": ("scene", "expert")}
PATH_FIELDS = {"convert": ("source", "mapping")}  # convert: `mapping` gets its digest, `source` does not


def portable(step: Step, folder: Path) -> Step:
    """`step` with each reference inside `folder` (the pipeline file's folder, absolute) written relative to it
    (with the referenced file's content digest, see the module's docstring)."""
    kind = step.kind
    spec = getattr(step, kind)
    update: dict[str, object] = {}
    for name in (*CONTENT_FIELDS.get(kind, ()), *PATH_FIELDS.get(kind, ())):
        value = getattr(spec, name)
        digest = name != "source"
        if isinstance(value, list):
            update[name] = [_reference(v, folder, digest) for v in value]
        elif isinstance(value, str):
            update[name] = _reference(value, folder, digest)
    if not update:
        return step
    return step.model_copy(update={kind: spec.model_copy(update=update)})


def _reference(ref: str, folder: Path, digest: bool) -> str:
    path = Path(ref)
    if not path.is_absolute() or not path.is_relative_to(folder):
        return ref  # a manifest id on the search path
    rel = path.relative_to(folder).as_posix()
    return f"{rel}#sha256={content_digest(path)}" if digest else rel


def content_digest(path: Path) -> str:
    """The sha256 of a file's bytes, or of a folder's files (relative path and digest of each regular file;
    ``__pycache__`` and hidden names left out: running the step writes them); a symlink inside a folder counts
    by its target's text (never followed), a file over `MAX_HASHED_BYTES` by its size."""
    if not path.is_dir():
        return _file_digest(path)
    h = hashlib.sha256()
    for rel in _tree(path)[:MAX_HASHED_FILES]:
        target = path / rel
        what = f"-> {os.readlink(target)}" if target.is_symlink() else _file_digest(target)
        h.update(f"{rel}\0{what}\n".encode())
    return h.hexdigest()


def _file_digest(path: Path) -> str:
    try:
        return hashlib.sha256(read_regular(path, MAX_HASHED_BYTES)).hexdigest()
    except ValueError:
        return f"size={path.stat().st_size}"
    except OSError as exc:  # missing, a FIFO: the step refuses it when it runs; the hash says what it saw
        return f"unreadable={type(exc).__name__}"


def _tree(root: Path) -> list[str]:
    found: list[str] = []
    for folder, dirs, files in os.walk(root):  # symlinked folders are not followed
        dirs[:] = sorted(d for d in dirs if not d.startswith(".") and d != "__pycache__")
        here = Path(folder).relative_to(root)
        found += [(here / f).as_posix() for f in sorted(files) if not f.startswith(".") and not f.endswith(".pyc")]
        if len(found) > MAX_HASHED_FILES:
            break
    return sorted(found)
