"""Content digests of the files a writer commits (`.openral/digests.json`), so `doctor` sees any changed byte.

The map is ``{relative path: {"sha256", "size", "ino"}}`` for info.json, stats.json, tasks, the episodes and
data parquet files and the mp4s. A writer stages it in the same commit batch as the files it describes, right
before info.json, so it always matches the committed dataset. Only files that changed are hashed: a file staged
in this commit (its ``.NAME.tmp`` sibling), a file new to the map, or one with another inode (every write of
ours replaces a file by rename, which gives it a new inode); an unchanged file keeps its recorded digest, so
a byte changed in place between two commits is not taken over by the next one.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from openral_data.errors import DatasetError
from openral_data.formats import atomic
from openral_data.formats.lerobot_v3 import layout
from openral_data.paths import contained

DIGESTS_PATH = ".openral/digests.json"
PATTERNS = (
    "meta/episodes/*/*.parquet",
    "data/*/*.parquet",
    "videos/*/*/*.mp4",
)
SINGLE = (layout.TASKS_PATH, layout.STATS_PATH, layout.INFO_PATH)
Digests = dict[str, dict[str, Any]]


def sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        while chunk := fh.read(1 << 20):
            h.update(chunk)
    return h.hexdigest()


def tracked(root: Path) -> list[str]:
    """Relative paths of the files the map covers that exist now or are staged (``.NAME.tmp``) for a commit."""
    found: set[str] = set()
    for pattern in PATTERNS:
        for p in root.glob(pattern):
            found.add(str(p.relative_to(root)))
        for p in root.glob(str(Path(pattern).parent / ".*.tmp")):
            final = p.with_name(p.name[1:-4])
            if Path(pattern).match(str(final.relative_to(root))):
                found.add(str(final.relative_to(root)))
    for rel in SINGLE:
        if (root / rel).is_file() or atomic.tmp_name(root / rel).is_file():
            found.add(rel)
    return sorted(found)


def read(root: Path) -> Digests | None:
    """The stored map, or None when the dataset has none (written by lerobot or an older openral-data)."""
    try:
        raw = atomic.read_control(root / DIGESTS_PATH)
    except FileNotFoundError:
        return None
    try:
        data = json.loads(raw)
    except (ValueError, UnicodeDecodeError) as exc:
        raise DatasetError(f"{root / DIGESTS_PATH}: invalid JSON: {exc}", code="dataset.invalid") from None
    ok = isinstance(data, dict) and all(
        isinstance(v, dict) and isinstance(v.get("sha256"), str) and isinstance(v.get("size"), int)
        for v in data.values()
    )
    if not ok:
        raise DatasetError(f"{root / DIGESTS_PATH}: not a map of path -> sha256 and size", code="dataset.invalid")
    out: Digests = {}
    for rel, entry in data.items():
        contained(root, rel, f"{root / DIGESTS_PATH}: key")
        out[rel] = entry
    return out


def compute(root: Path, previous: Digests, extra: dict[str, bytes]) -> Digests:
    """The map of the files as this commit leaves them; `extra` holds files not written yet (info.json)."""
    out: Digests = {}
    for rel in tracked(root):
        if rel in extra:
            continue
        final = root / rel
        staged = atomic.tmp_name(final)
        source = staged if staged.is_file() else final
        st = source.stat()
        old = previous.get(rel)
        if source is final and old is not None and old.get("ino") == st.st_ino and old.get("size") == st.st_size:
            out[rel] = old
            continue
        out[rel] = {"sha256": sha256_file(source), "size": st.st_size, "ino": st.st_ino}
    for rel, data in extra.items():
        out[rel] = {"sha256": hashlib.sha256(data).hexdigest(), "size": len(data)}
    return dict(sorted(out.items()))


def _previous(root: Path) -> Digests:
    try:
        return read(root) or {}
    except DatasetError:
        return {}


def writer(root: Path, extra: dict[str, bytes]) -> Callable[[Path], None]:
    """A `writer` for `atomic.Batch.write_with` that stages the updated map (call it after the other files)."""

    def write(path: Path) -> None:
        path.write_text(json.dumps(compute(root, _previous(root), extra), indent=1))

    return write


def refresh(root: Path, changed_paths: Iterable[Path], durable: bool = True) -> None:
    """After a write outside a commit batch (`doctor --repair`, a writer's video join) rewrote or removed
    `changed_paths`: their entries follow them; the others stay."""
    stored = read(root)
    if stored is None:
        return
    ours = set(tracked(root))
    for path in changed_paths:
        rel = str(path.relative_to(root))
        if not path.is_file():
            stored.pop(rel, None)
        elif rel in stored or rel in ours:
            st = path.stat()
            stored[rel] = {"sha256": sha256_file(path), "size": st.st_size, "ino": st.st_ino}
    atomic.write_bytes(root / DIGESTS_PATH, json.dumps(dict(sorted(stored.items())), indent=1).encode(), durable)


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
