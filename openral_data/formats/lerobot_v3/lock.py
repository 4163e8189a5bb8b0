"""One writer per dataset: an exclusive fcntl lock on ``DATASET/.openral/lock``.

flock locks belong to the open file, so the kernel drops them when the holder dies, SIGKILL included: a lock
file left behind by a killed recording is stale by construction and the next writer simply takes it. The
file names its holder (pid, command, start time) for the refusal message. The lock file and ``.openral`` are
opened as control files (`atomic.open_control`, `atomic.state_dir`): a symlink, FIFO or device there is refused.
"""

from __future__ import annotations

import errno
import fcntl
import os
from datetime import UTC, datetime
from pathlib import Path
from types import TracebackType

from openral_data.errors import DISK_ERRNOS, DatasetBusy, DatasetError, DiskError
from openral_data.formats import atomic
from openral_data.formats.lerobot_v3 import layout

READONLY = (errno.EROFS, errno.EACCES, errno.EPERM)


class DatasetLock:
    def __init__(self, root: Path, purpose: str) -> None:
        self.root = root
        self.path = root / layout.LOCK_PATH
        self.purpose = purpose
        self._fd: int | None = None

    def acquire(self) -> DatasetLock:
        """Take the lock; a read-only dataset, or a full or failing disk while creating or stamping the lock file,
        is one line."""
        try:
            return self._acquire()
        except OSError as exc:
            if exc.errno in READONLY:
                raise DatasetError(
                    f"{self.root}: cannot be written ({exc.strerror}); commands that only read it still work",
                    code="dataset.readonly",
                ) from None
            if exc.errno in DISK_ERRNOS:
                raise DiskError(self.root, exc.errno, f"taking its writer lock ({layout.LOCK_PATH})") from exc
            raise

    def _acquire(self) -> DatasetLock:
        atomic.state_dir(self.root)
        while True:
            fd = atomic.open_control(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                holder = os.pread(fd, 200, 0).decode(errors="replace").strip() or "unknown process"
                os.close(fd)
                raise DatasetBusy(self.root, holder) from None
            # the previous holder may have removed the file between our open and our lock: lock the live one
            try:
                same = os.path.samestat(os.fstat(fd), os.lstat(self.path))
            except FileNotFoundError:
                same = False
            if not same:
                os.close(fd)
                continue
            try:
                os.ftruncate(fd, 0)
                stamp = datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
                os.pwrite(fd, f"pid {os.getpid()}, {self.purpose}, since {stamp}\n".encode(), 0)
            except BaseException:
                os.close(fd)  # let go of the lock we could not stamp
                raise
            self._fd = fd
            return self

    def release(self) -> None:
        if self._fd is None:
            return
        self.path.unlink(missing_ok=True)  # while still holding it (a waiter re-checks the inode)
        os.close(self._fd)
        self._fd = None

    def __enter__(self) -> DatasetLock:
        return self.acquire()

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.release()


def holder(root: Path) -> str | None:
    """Who holds the dataset's lock right now, or None when nobody does (a stale file is nobody).

    A lock file that is not a regular file (a symlink, a FIFO) is nobody's: no writer of ours can hold it
    (`DatasetLock` refuses it); `doctor` reports it as ``control.unsafe``. An unreadable one is nobody's too.
    """
    path = root / layout.LOCK_PATH
    try:
        fd = atomic.open_control(path)
    except (DatasetError, OSError):  # missing, unreadable, or not a regular file: no writer of ours holds it
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return os.pread(fd, 200, 0).decode(errors="replace").strip() or "unknown process"
    finally:
        os.close(fd)
    return None


def check_settled(root: Path, verb: str) -> None:
    """Refuse, in one line, to `verb` (read and use) `root` while a writer holds it (``dataset.busy``) or while an
    episode commit is unfinished (its journal is there: ``dataset.interrupted``, `doctor --repair` finishes it)."""
    busy = holder(root)
    if busy is not None:
        raise DatasetBusy(root, busy, to_edit=True, verb=verb)
    if os.path.lexists(root / layout.JOURNAL_PATH):
        raise DatasetError(
            f"{root}: an episode commit was interrupted; run `openral-data doctor --repair` first",
            code="dataset.interrupted",
        )
