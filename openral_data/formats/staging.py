"""Outputs that appear complete or not at all: build in a hidden staging folder, rename it into place.

A command that writes a new dataset or a folder of bags (`convert`, `episodes delete/split/merge`, `record
--workers`) builds it in ``PARENT/.NAME.partial-PID`` — a hidden name no LeRobot or openral-data reader takes
for the output — and renames it to ``PARENT/NAME`` only when every file is written and fsynced. A killed run
leaves nothing under the destination's name.

Beside the folder, its marker ``.NAME.partial-PID.owner`` names the owner (pid, command, start time) and is
flock-ed by it for as long as it lives: the kernel drops the lock when the owner dies (SIGKILL included). The
marker sits outside the folder so the folder holds exactly what will be published. `clean_orphans(parent)`,
run by every writing command before it writes into `parent`, removes the staging folders there whose marker
is not locked (their owner is dead) — and those without a marker whose pid no longer runs — so a killed run
costs its partial output, never a refused re-run or a stray hidden folder.
"""

from __future__ import annotations

import errno
import fcntl
import os
import re
import shutil
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path

from openral_data.errors import DatasetError, OutputExists, WriteError
from openral_data.formats.atomic import fsync_dir, fsync_tree, open_control
from openral_data.formats.lerobot_v3.loadable import check_loadable
from openral_data.paths import check_creatable

MARKER_SUFFIX = ".owner"
_PATTERN = re.compile(r"^\..+\.partial-(\d+)$")
_MARKER_PATTERN = re.compile(r"^(\..+\.partial-\d+)\.owner$")


def staging_name(out: Path) -> Path:
    return out.parent / f".{out.name}.partial-{os.getpid()}"


def marker_of(folder: Path) -> Path:
    return folder.with_name(folder.name + MARKER_SUFFIX)


def unwritable(out: Path, exc: OSError) -> WriteError:
    """The one-line error for an output that cannot be created (read-only file system, permissions, full disk)."""
    return WriteError(f"{out}: cannot write the output here: {exc.strerror or exc}")


def check_new_output(out: Path, what: str = "output") -> None:
    """Refuse an `out` that holds anything (an empty folder is taken over) or that cannot be created."""
    check_creatable(out, what, folder=False)
    if out.is_symlink() or (out.exists() and (not out.is_dir() or any(out.iterdir()))):
        raise OutputExists(f"{out}: {what} exists and is not empty; refusing to overwrite it")


class Staging:
    """A hidden staging folder for `out`, owned (marker + flock) by this process until `publish` or `discard`."""

    def __init__(self, out: Path, purpose: str, create: bool = True) -> None:
        self.out = out
        self.path = staging_name(out)
        self.purpose = purpose
        self.create = create  # False: the writer creates the folder itself (one that refuses an existing one)
        self._fd: int | None = None

    def open(self) -> Path:
        """Clean orphans beside `out`, then take the locked marker and create the staging folder; returns it."""
        try:
            return self._open()
        except OSError as exc:
            self.discard()
            raise unwritable(self.out, exc) from None

    def _open(self) -> Path:
        self.out.parent.mkdir(parents=True, exist_ok=True)
        clean_orphans(self.out.parent)
        marker = marker_of(self.path)
        tmp = marker.with_name(marker.name + ".tmp")
        tmp.unlink(missing_ok=True)
        fd = open_control(tmp, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o644)
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # locked before it takes its name: never seen unlocked
        stamp = datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
        os.write(fd, f"pid {os.getpid()}, {self.purpose}, since {stamp}\n".encode())
        os.replace(tmp, marker)
        self._fd = fd
        shutil.rmtree(self.path, ignore_errors=True)  # this pid's own leftover (a reused pid)
        if self.create:
            self.path.mkdir()
        return self.path

    def publish(self, what: str = "output", before_rename: Callable[[], None] | None = None) -> None:
        """fsync every file, then rename the staging folder to `out` (an empty `out` folder is replaced).

        `before_rename()` runs right before the final check and rename (e.g. to let go of a lock on `out`). A
        LeRobot v3 dataset lerobot 0.6.1 could not load is refused first (`loadable.check_loadable`)."""
        check_loadable(self.path, self.out)
        fsync_tree(self.path)
        if before_rename is not None:
            before_rename()
        check_new_output(self.out, what)
        if self.out.is_dir():
            self.out.rmdir()
        try:
            os.replace(self.path, self.out)
        except OSError as exc:
            if exc.errno in (errno.ENOTEMPTY, errno.EEXIST, errno.ENOTDIR):
                raise OutputExists(f"{self.out}: {what} appeared while it was being written; not replaced") from None
            raise
        self._close()
        fsync_dir(self.out.parent)

    def replace_existing(self, aside: Path) -> None:
        """fsync, move the existing `out` to `aside`, rename the staging folder to `out`, then remove `aside`.

        Killed between the two renames, the old `out` is whole under `aside` (a name `clean_orphans` never takes);
        a failed second rename (EIO) puts it back under its name. Refused first like `publish`.
        """
        check_loadable(self.path, self.out)
        fsync_tree(self.path)
        os.replace(self.out, aside)
        try:
            os.replace(self.path, self.out)
        except OSError:
            os.replace(aside, self.out)
            raise
        self._close()
        fsync_dir(self.out.parent)
        shutil.rmtree(aside)

    def discard(self) -> None:
        shutil.rmtree(self.path, ignore_errors=True)
        self._close()

    def _close(self) -> None:
        """Remove the marker (still holding its lock), then let go of it."""
        if self._fd is not None:
            marker_of(self.path).unlink(missing_ok=True)
            os.close(self._fd)
            self._fd = None

    def __enter__(self) -> Path:
        return self.open()

    def __exit__(self, exc_type: object, exc: object, tb: object) -> None:
        if self._fd is not None:  # not published: an error or an interrupt
            self.discard()


def clean_orphans(parent: Path) -> list[Path]:
    """Remove the staging folders under `parent` whose owner is dead; returns what was removed."""
    removed: list[Path] = []
    try:
        entries = list(parent.iterdir())
    except OSError:
        return removed
    for entry in entries:
        found = _PATTERN.match(entry.name)
        if found is None or entry.is_symlink() or not entry.is_dir():
            continue
        if _owned(entry, int(found.group(1))):
            continue
        shutil.rmtree(entry, ignore_errors=True)
        marker_of(entry).unlink(missing_ok=True)
        removed.append(entry)
    for entry in entries:  # a marker whose folder is gone (killed between the rename and the marker's removal)
        found = _MARKER_PATTERN.match(entry.name)
        if found is not None and not (parent / found.group(1)).exists() and not _locked(entry):
            entry.unlink(missing_ok=True)
    return removed


def _owned(folder: Path, pid: int) -> bool:
    """Whether a live process still owns `folder`: its marker is locked, or (no marker) its pid runs."""
    if not marker_of(folder).exists():
        return pid == os.getpid() or _alive(pid)
    return _locked(marker_of(folder))


def _locked(marker: Path) -> bool:
    try:
        fd = open_control(marker)
    except FileNotFoundError:
        return False
    except (OSError, DatasetError):  # unreadable, or not a regular file: not ours to judge, left alone
        return True
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    finally:
        os.close(fd)
    return False


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True
