"""The one error a failed write of a dataset's files becomes, for every writer in `formats`."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from openral_data.errors import DISK_ERRNOS, DiskError, WriteError


def write_error(
    root: Path, exc: OSError, doing: str, committed: bool = False, *, message: str | None = None
) -> WriteError:
    """One line for a failed write under `root` while `doing`: a `DiskError` for a disk problem (`committed`: the
    episode is committed nevertheless), else a `WriteError` with `message` (default: the OS error and `doing`)."""
    if exc.errno in DISK_ERRNOS:
        return DiskError(root, exc.errno, doing, committed=committed)
    return WriteError(f"{root}: {message if message is not None else f'{exc.strerror or exc} while {doing}'}")


@contextmanager
def disk_errors(root: Path, doing: str) -> Iterator[None]:
    """A full or failing disk (ENOSPC, EIO, EROFS, EDQUOT) inside the block becomes one `DiskError` line about
    `root` (an edit's output; an in-place edit's dataset rather than its hidden staging folder); any other
    OSError passes unchanged."""
    try:
        yield
    except DiskError as exc:
        if exc.path == root:
            raise
        raise DiskError(root, exc.errno, doing) from exc
    except OSError as exc:
        if exc.errno not in DISK_ERRNOS:
            raise
        raise DiskError(root, exc.errno, doing) from exc
