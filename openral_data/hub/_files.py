"""Which files of a dataset a push uploads: what lerobot's loader reads (``meta/``, ``data/``, ``videos/``) and,
when asked, our MCAP bags (``mcap/``) and our bookkeeping (``.openral/``); nothing else.

Hidden files inside those folders (a ``.NAME.tmp`` a writer staged) are never uploaded, and neither is the
writer lock. A symlink is followed only while it stays inside the dataset (`paths.contained`); a FIFO or a
device is refused (`paths.regular_file`), so a dataset cannot make a push upload anything from outside it.
"""

from __future__ import annotations

import os
from pathlib import Path

from openral_data.errors import DatasetError
from openral_data.formats.lerobot_v3 import layout
from openral_data.paths import contained, regular_file

DATASET_DIRS = ("meta", "data", "videos")
MCAP_DIR = "mcap"
NEVER = (layout.LOCK_PATH,)  # a live writer's lock file says nothing about the data


def select_files(root: Path, *, include_mcap: bool = False, include_state: bool = False) -> list[str]:
    """The dataset-relative POSIX paths a push of `root` uploads, sorted."""
    folders = [*DATASET_DIRS, *((MCAP_DIR,) if include_mcap else ()), *((layout.STATE_DIR,) if include_state else ())]
    found: list[str] = []
    for folder in folders:
        found += _walk(root, folder)
    return sorted(rel for rel in found if rel not in NEVER)


def _walk(root: Path, folder: str) -> list[str]:
    """Every regular file under `root/folder`, as relative paths; symlinks leading out and special files refused,
    a folder reached twice (a symlink loop inside the dataset) walked once."""
    if not os.path.lexists(root / folder):
        return []
    found: list[str] = []
    seen: set[Path] = set()
    pending = [folder]
    while pending:
        rel_dir = pending.pop()
        here = contained(root, rel_dir, f"{root}: {rel_dir}")
        if not here.is_dir():
            found.append(_file(root, rel_dir))
            continue
        if here.resolve() in seen:
            continue
        seen.add(here.resolve())
        for entry in sorted(os.listdir(here)):
            if entry.startswith("."):
                continue  # staged temporaries (.NAME.tmp) and other hidden files are not the dataset's
            rel = f"{rel_dir}/{entry}"
            if contained(root, rel, f"{root}: {rel}").is_dir():
                pending.append(rel)
            else:
                found.append(_file(root, rel))
    return found


def _file(root: Path, rel: str) -> str:
    path = contained(root, rel, f"{root}: {rel}")
    try:
        regular_file(path)
    except FileNotFoundError:
        raise DatasetError(f"{path}: a broken symlink; nothing to upload there", code="dataset.incomplete") from None
    return rel
