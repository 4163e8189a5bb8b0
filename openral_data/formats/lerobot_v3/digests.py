"""Content digests of the files a writer commits, so `doctor` sees any changed byte.

The map is ``{relative path: {"sha256", "size", "ino"}}`` for info.json, stats.json, tasks, the episodes and
data parquet files and the mp4s. It is kept in two parts so a commit costs O(that episode), however many files
the dataset has:

* ``.openral/digests.json``, the base: ``{"through": E, "files": {...}}`` (an older plain map reads as
  ``through = -1``), rewritten only by `refresh` (a consolidation, a video join, a repair, a recovery);
* ``.openral/digests.d/<episode>.json``, one delta per episode commit: the entries of the files that commit
  wrote (its own data and episodes files, its mp4s, stats, tasks, info.json). A writer stages it in the same
  commit batch as those files, right before info.json, so it always matches the committed dataset.

`read` applies the deltas above ``through`` to the base in episode order. `refresh` folds them into a new base
and removes them. Files are hashed as they are written (a staged ``.NAME.tmp`` keeps its inode when renamed);
an unchanged file keeps its recorded digest, so a byte changed in place between two commits is never taken over.

A join rewrites and removes files outside any commit batch: `mark` first lists them durably in
``.openral/rehash.json``; `refresh` clears it once their entries follow them. A crash in between leaves the
list for `recovery` to finish (`pending`), so a crash never leaves digests that accuse our own writes.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from openral_data.errors import DatasetError
from openral_data.formats import atomic
from openral_data.formats.jsonfile import parse_json
from openral_data.formats.lerobot_v3 import layout
from openral_data.paths import contained, contained_all

DIGESTS_PATH = ".openral/digests.json"
DELTAS_DIR = "digests.d"  # below .openral
REHASH_PATH = ".openral/rehash.json"
PATTERNS = (
    "meta/episodes/*/*.parquet",
    "data/*/*.parquet",
    "videos/*/*/*.mp4",
)
SINGLE = (layout.TASKS_PATH, layout.STATS_PATH, layout.INFO_PATH)
_DELTA = re.compile(r"^(\d{9})\.json$")
Digests = dict[str, dict[str, Any]]


def sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        while chunk := fh.read(1 << 20):
            h.update(chunk)
    return h.hexdigest()


def is_tracked(rel: str) -> bool:
    """Whether the map covers the file at `rel` (relative to the dataset root)."""
    return rel in SINGLE or any(Path(rel).match(p) for p in PATTERNS)


def entry(path: Path) -> dict[str, Any]:
    st = path.stat()
    return {"sha256": sha256_file(path), "size": st.st_size, "ino": st.st_ino}


def delta_path(root: Path, episode: int) -> Path:
    """Where the digests of episode `episode`'s commit go (its folder is checked to be a real one)."""
    return atomic.state_dir(root, DELTAS_DIR) / f"{episode:09d}.json"


def _files(root: Path, data: Any, where: Path) -> Digests:
    ok = isinstance(data, dict) and all(
        isinstance(v, dict) and isinstance(v.get("sha256"), str) and isinstance(v.get("size"), int)
        for v in data.values()
    )
    if not ok:
        raise DatasetError(f"{where}: not a map of path -> sha256 and size", code="dataset.invalid")
    contained_all(root, [str(rel) for rel in data], f"{where}: key")
    return dict(data)


def _load(path: Path) -> Any:
    raw = atomic.read_control(path)
    try:
        return parse_json(raw)
    except ValueError as exc:
        raise DatasetError(f"{path}: invalid JSON: {exc}", code="dataset.invalid") from None


def _base(root: Path) -> tuple[Digests, int] | None:
    path = root / DIGESTS_PATH
    try:
        data = _load(path)
    except FileNotFoundError:
        return None
    if isinstance(data, dict) and set(data) == {"through", "files"}:
        if not isinstance(data["through"], int):
            raise DatasetError(f"{path}: through: not an integer", code="dataset.invalid")
        return _files(root, data["files"], path), data["through"]
    return _files(root, data, path), -1


def deltas(root: Path) -> list[tuple[int, Path]]:
    """The per-commit delta files, in episode order (a symlinked folder is refused, stray names ignored)."""
    folder = root / layout.STATE_DIR / DELTAS_DIR
    if not os.path.lexists(folder):
        return []
    if folder.is_symlink() or not folder.is_dir():
        raise DatasetError(f"{folder}: not a real folder; refusing to use it", code="dataset.unsafe")
    found = [(int(m.group(1)), folder / name) for name in os.listdir(folder) if (m := _DELTA.match(name))]
    return sorted(found)


def read(root: Path) -> Digests | None:
    """The stored map, or None when the dataset has none (written by lerobot or an older openral-data)."""
    return _stored(root)[0]


def _stored(root: Path) -> tuple[Digests | None, int, list[tuple[int, Path]]]:
    """The map (the base with the deltas above its ``through`` applied, or None), the highest episode it
    covers, and every delta file on disk (also those at or below ``through`` a crashed refresh left)."""
    base = _base(root)
    out, through = base if base is not None else ({}, -1)
    every = deltas(root)
    found = [(k, p) for k, p in every if k > through]
    if base is None and not found:
        return None, through, every
    for _, path in found:
        data = _load(path)
        out.update(_files(root, data.get("files") if isinstance(data, dict) else None, path))
    return out, max([through, *(k for k, _ in found)]), every


def delta_writer(root: Path, files: Iterable[tuple[Path, Path]], extra: dict[str, bytes]) -> Callable[[Path], None]:
    """A `writer` for `atomic.Batch.write_with` that stages one commit's delta: `files` are (what to hash,
    final path) pairs, the staged ``.NAME.tmp`` of a file not renamed yet or the file itself; `extra` holds
    files not written yet (info.json)."""
    pairs = list(files)

    def write(path: Path) -> None:
        out: Digests = {}
        for source, final in pairs:
            rel = str(final.relative_to(root))
            if is_tracked(rel):
                out[rel] = entry(source)
        for rel, data in extra.items():
            out[rel] = {"sha256": hashlib.sha256(data).hexdigest(), "size": len(data)}
        path.write_text(json.dumps({"files": dict(sorted(out.items()))}, indent=1))

    return write


def mark(root: Path, paths: Iterable[Path], durable: bool = True) -> None:
    """Before files are rewritten or removed outside a commit batch: list them, so a crash is finished."""
    rels = sorted({str(p.relative_to(root)) for p in paths} | set(_pending_rels(root)))
    atomic.state_dir(root)
    atomic.write_bytes(root / REHASH_PATH, json.dumps(rels).encode(), durable)


def _pending_rels(root: Path) -> list[str]:
    try:
        data = _load(root / REHASH_PATH)
    except FileNotFoundError:
        return []
    if not isinstance(data, list) or not all(isinstance(r, str) for r in data):
        raise DatasetError(f"{root / REHASH_PATH}: not a list of paths", code="dataset.invalid")
    return [r for r in data if is_tracked(r)]


def pending(root: Path) -> list[Path]:
    """The files a join listed with `mark` and whose digests may not follow them yet (a crash in between)."""
    return [contained(root, rel, f"{root / REHASH_PATH}: entry") for rel in _pending_rels(root)]


def refresh(root: Path, changed_paths: Iterable[Path], durable: bool = True) -> None:
    """After writes outside a commit batch (a join, `doctor --repair`, a recovery) rewrote or removed
    `changed_paths`: their entries follow them, the others stay; the deltas fold into a new base, and the
    `mark`ed list is cleared. A dataset without digests (not written by us) is left without."""
    stored, through, found = _stored(root)
    if stored is not None:
        for path in [*changed_paths, *pending(root)]:
            rel = str(path.relative_to(root))
            if not path.is_file():
                stored.pop(rel, None)
            elif is_tracked(rel):
                stored[rel] = entry(path)
        body = {"through": through, "files": dict(sorted(stored.items()))}
        atomic.write_bytes(root / DIGESTS_PATH, json.dumps(body, indent=1).encode(), durable)
    for _, path in found:
        path.unlink()
    (root / REHASH_PATH).unlink(missing_ok=True)
    if durable and found:
        atomic.fsync_dir(found[0][1].parent)
    if durable and (found or stored is not None):
        atomic.fsync_dir(root / layout.STATE_DIR)


def changed(root: Path, stored: Digests) -> list[tuple[str, str]]:
    """(relative path, what differs) for every file of the map whose bytes are not the recorded ones."""
    out: list[tuple[str, str]] = []
    for rel, want in stored.items():
        path = root / rel
        if not path.is_file():
            out.append((rel, "missing"))
            continue
        size = os.stat(path).st_size
        if size != want["size"]:
            out.append((rel, f"{size} bytes, {want['size']} were written"))
        elif sha256_file(path) != want["sha256"]:
            out.append((rel, "content differs from what was written (sha256)"))
    return out
