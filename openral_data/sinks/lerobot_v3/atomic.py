"""Atomic file replacement: write beside the target, flush to disk, then rename over it."""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator
from pathlib import Path


def fsync_dir(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def tmp_name(path: Path) -> Path:
    """A sibling name no LeRobot glob (`*.parquet`, `*.mp4`) matches."""
    return path.with_name(f".{path.name}.tmp")


@contextlib.contextmanager
def replacing(path: Path, durable: bool = True) -> Iterator[Path]:
    """Yield a temporary path to write; on success it atomically becomes `path`."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = tmp_name(path)
    try:
        yield tmp
        if durable:
            with open(tmp, "rb+") as fh:
                os.fsync(fh.fileno())
        os.replace(tmp, path)
        if durable:
            fsync_dir(path.parent)
    finally:
        if tmp.exists():
            tmp.unlink()


def write_bytes(path: Path, data: bytes, durable: bool = True) -> None:
    with replacing(path, durable) as tmp:
        tmp.write_bytes(data)


def write_with(path: Path, writer: Callable[[Path], None], durable: bool = True) -> None:
    with replacing(path, durable) as tmp:
        writer(tmp)


class Batch:
    """Several files written beside their targets first, then renamed into place one after the other.

    Preparing every file before the first rename shrinks the moment in which a reader could see some of the
    new files but not the others to a few renames; the renames happen in write order, so the file that makes
    the others count (info.json) is written last and lands last.
    """

    def __init__(self, durable: bool = True) -> None:
        self.durable = durable
        self._staged: list[tuple[Path, Path]] = []

    def write_with(self, path: Path, writer: Callable[[Path], None]) -> None:
        if any(final == path for _, final in self._staged):
            raise ValueError(f"{path} is already staged in this batch")
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = tmp_name(path)
        try:
            writer(tmp)
            if self.durable:
                with open(tmp, "rb+") as fh:
                    os.fsync(fh.fileno())
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
        self._staged.append((tmp, path))

    def commit(self) -> None:
        for tmp, path in self._staged:
            os.replace(tmp, path)
        if self.durable:
            for parent in dict.fromkeys(path.parent for _, path in self._staged):
                fsync_dir(parent)
        self._staged.clear()

    def discard(self) -> None:
        for tmp, _ in self._staged:
            tmp.unlink(missing_ok=True)
        self._staged.clear()
