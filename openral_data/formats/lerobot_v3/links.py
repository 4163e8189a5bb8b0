"""Symbolic links in a dataset's folders that lead out of it.

A link that stays inside the dataset is fine; one under ``meta/``, ``data/``, ``videos/`` or ``mcap/`` (or one
of those folders itself) whose target lies outside makes every reader read, and every writer write, someone
else's files. `doctor` reports each one (`outside_links`); `doctor --repair` and `record --resume` refuse such
a dataset before touching anything (`refuse_outside_links`). The layout functions refuse the same paths one by
one (`layout.data_path`, `layout.video_path`, ...), so no reader or writer can follow one either.
"""

from __future__ import annotations

import os
from pathlib import Path

from openral_data.errors import DatasetError

LINKED_DIRS = ("meta", "data", "videos", "mcap")  # what our readers and writers open below a dataset


def outside_links(root: Path) -> list[tuple[str, str]]:
    """(dataset-relative path, target) of every symlink below `root`'s `LINKED_DIRS` leading outside `root`,
    in walk order. Links are never followed out; a folder linked from inside is walked once."""
    base = root.resolve()
    found: list[tuple[str, str]] = []
    seen: set[Path] = set()
    pending = [name for name in reversed(LINKED_DIRS) if os.path.lexists(root / name)]
    while pending:
        rel = pending.pop()
        path = root / rel
        try:
            target = path.resolve()
        except (RuntimeError, OSError):  # a symlink loop (RuntimeError before Python 3.13): it leads nowhere inside
            found.append((rel, f"{os.readlink(path)}, a symlink loop"))
            continue
        if not target.is_relative_to(base):
            found.append((rel, os.readlink(path) if path.is_symlink() else str(target)))
            continue
        if not target.is_dir() or target in seen:
            continue
        seen.add(target)
        with os.scandir(path) as entries:
            names = sorted(e.name for e in entries if e.is_symlink() or e.is_dir(follow_symlinks=False))
        pending += [f"{rel}/{name}" for name in reversed(names)]
    return found


def refuse_outside_links(root: Path, command: str) -> None:
    """One line (``dataset.unsafe``) naming the first symlink below `root` that leads out, before `command`
    touches anything; nothing when there is none."""
    found = outside_links(root)
    if found:
        rel, target = found[0]
        more = f" (and {len(found) - 1} more)" if len(found) > 1 else ""
        raise DatasetError(
            f"{root / rel}: a symbolic link leading outside the dataset (to {target}){more}; {command} refuses "
            "a dataset whose folders lead out",
            code="dataset.unsafe",
        )
