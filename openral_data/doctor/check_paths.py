"""Paths a dataset's own files could turn against us: control files that are not regular files, a commit
journal whose entries lead outside the dataset, symlinks in its folders leading out, feature keys that are not
one path component, chunk/file indices that are not small non-negative integers, and path templates other than
lerobot's.

Each is an error finding that `doctor --repair` never "repairs" by following it: a repair refuses unsafe
control files and journals in one line (`DatasetLock`, `atomic.replay_journal`) and leaves keys and templates
alone. Nothing here opens a file that could block (FIFOs) or follows a symlink: control files are only
`lstat`-ed, and the journal is read with `atomic.read_control`.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from openral_data.doctor.findings import Finding, error
from openral_data.doctor.inspect import Dataset
from openral_data.errors import DatasetError
from openral_data.formats import atomic
from openral_data.formats.lerobot_v3 import digests, layout
from openral_data.formats.lerobot_v3.links import outside_links
from openral_data.paths import safe_name

CONTROL_FILES = (layout.LOCK_PATH, layout.JOURNAL_PATH, layout.RECORD_PATH, layout.IMAGE_HIST_PATH, digests.REHASH_PATH)
CONTROL_DIRS = (layout.STATE_DIR, layout.QUARANTINE_DIR)
# findings after which the other checks would build paths from the offending values: they stop there
BLOCKING = frozenset({"features.unsafe_key", "episodes.file_index"})


def check_controls(root: Path) -> list[Finding]:
    """The control files and folders under ``.openral``, the commit journal (``writer.journal`` when it
    can be finished safely, ``journal.unsafe`` / ``journal.invalid`` when it cannot) and the re-hash list."""
    out: list[Finding] = []
    for rel in CONTROL_DIRS:
        kind = _kind(root / rel)
        if kind not in (None, "folder"):
            out.append(error("control.unsafe", rel, f"is a {kind}, not a folder; nothing of ours follows it"))
            return out  # what lies below it is not ours to look at
    for rel in CONTROL_FILES:
        kind = _kind(root / rel)
        if kind not in (None, "file"):
            out.append(error("control.unsafe", rel, f"is a {kind}, not a regular file; nothing of ours opens it"))
    if _kind(root / layout.JOURNAL_PATH) == "file":
        out.append(_journal(root))
    if _kind(root / digests.REHASH_PATH) == "file":
        out += _rehash(root)
    return out


def check_links(root: Path) -> list[Finding]:
    """Each symlink under ``meta/``, ``data/``, ``videos/`` or ``mcap/`` leading outside the dataset
    (`links.outside_links`): no other check reads through one, and `--repair` / `record --resume` refuse it."""
    message = "a symbolic link leading outside the dataset (to {}); nothing of ours follows it"
    return [error("path.outside", rel, message.format(target)) for rel, target in outside_links(root)]


def _rehash(root: Path) -> list[Finding]:
    """The files a join listed for re-hashing: recovery (`record --resume`, `--repair`) re-hashes each, so one
    that leads outside the dataset (`rehash.unsafe`) or a list that is not one (`rehash.invalid`) is an error."""
    try:
        digests.pending(root)
    except DatasetError as exc:
        code = "rehash.unsafe" if exc.code == "dataset.unsafe" else "rehash.invalid"
        return [error(code, digests.REHASH_PATH, f"{exc} (not followed; inspect or remove it by hand)")]
    return []


def _journal(root: Path) -> Finding:
    try:
        atomic.journal_renames(root / layout.JOURNAL_PATH)
    except DatasetError as exc:
        code = "journal.unsafe" if exc.code == "dataset.unsafe" else "journal.invalid"
        return error(code, layout.JOURNAL_PATH, f"{exc} (not replayed; inspect or remove it by hand)")
    return error(
        "writer.journal",
        layout.JOURNAL_PATH,
        "an episode commit was interrupted (a killed writer); lerobot still sees the previous episodes",
        repairable=True,
    )


def _kind(path: Path) -> str | None:
    try:
        mode = os.lstat(path).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return None
    if stat.S_ISLNK(mode):
        return "symbolic link"
    if stat.S_ISDIR(mode):
        return "folder"
    if stat.S_ISREG(mode):
        return "file"
    if stat.S_ISFIFO(mode):
        return "FIFO"
    return "special file"


def check_dataset_paths(ds: Dataset) -> list[Finding]:
    """Feature keys, path templates and the episodes' chunk/file indices of a loaded dataset."""
    out: list[Finding] = []
    for key in ds.video_keys:
        try:
            safe_name(key, "features")
        except DatasetError:
            out.append(error("features.unsafe_key", layout.INFO_PATH, f"video feature {key!r} is not a folder name"))
    for field, standard in layout.TEMPLATES.items():
        value = ds.info.get(field)
        if value is not None and value != standard:
            message = f"{field} {value!r} is not lerobot's {standard!r}; nothing of ours follows it"
            out.append(error("info.template", layout.INFO_PATH, message))
    out += _indices(ds)
    return out


def _indices(ds: Dataset) -> list[Finding]:
    if ds.episodes is None:
        return []
    prefixes = ["data", "meta/episodes"] + [f"videos/{k}" for k in ds.video_keys]
    for prefix in prefixes:
        for name in (f"{prefix}/chunk_index", f"{prefix}/file_index"):
            if name not in ds.episodes.column_names:
                continue
            for value in ds.episodes.column(name).to_pylist():
                if value is None:
                    continue
                try:
                    layout.FilePos(value, 0)
                except DatasetError:
                    message = f"{name} {value!r} is not an integer in [0, {layout.MAX_INDEX})"
                    return [error("episodes.file_index", "meta/episodes", message)]
    return []
