"""Fault injection: make the Nth file-system call of a commit raise `OSError(errno)`, as a full or failing disk.

`inject(faults)` patches, for the length of a `with`, the calls through which our writers put bytes on disk:
`os.fsync`, `os.replace`, `os.rename`, `Path.write_bytes` (JSON files), pyarrow's `pq.write_table` and
`ParquetWriter.write_table` (parquet files; pyarrow writes through its own C++ I/O, so its Python entry points
are where a write can be made to fail), the mp4 join (`concat_mp4`, called by the LeRobot writer) and the
rosbags writer's `write` / `close` (the MCAP sink's messages and its summary). Each call counts once `faults`
is armed; call number `fail_at` raises, and with `persist` every later call too (a disk that stays full).
A clean run with `fail_at=None` counts the calls (`faults.calls` names each), so a test can then fail each.
"""

from __future__ import annotations

import errno
import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pyarrow.parquet as pq
from rosbags.rosbag2 import Writer

from openral_data.formats.lerobot_v3 import joins as lerobot_joins


@dataclass
class Faults:
    fail_at: int | None = None  # 1-based number of the call that fails; None: count only
    errno: int = errno.ENOSPC
    persist: bool = True  # every call after `fail_at` fails too
    armed: bool = False  # calls count (and fail) only once armed
    calls: list[str] = field(default_factory=list)

    @property
    def failed(self) -> bool:
        return self.fail_at is not None and len(self.calls) >= self.fail_at

    def check(self, label: str) -> None:
        if not self.armed:
            return
        self.calls.append(label)
        n = len(self.calls)
        if self.fail_at is not None and (n == self.fail_at or (self.persist and n > self.fail_at)):
            raise OSError(self.errno, os.strerror(self.errno), label)


def _name(value: Any) -> str:
    return Path(value).name if isinstance(value, str | os.PathLike) else ""


# (owner, attribute, label for a call from its arguments)
TARGETS: list[tuple[Any, str, Callable[..., str]]] = [
    (os, "fsync", lambda *a, **k: "fsync"),
    (os, "replace", lambda src, dst, *a, **k: f"replace {_name(dst)}"),
    (os, "rename", lambda src, dst, *a, **k: f"rename {_name(dst)}"),
    (Path, "write_bytes", lambda self, *a, **k: f"write {self.name}"),
    (pq, "write_table", lambda table, where, *a, **k: f"parquet {_name(where)}"),
    (pq.ParquetWriter, "write_table", lambda self, *a, **k: "parquet rows"),
    (lerobot_joins, "concat_mp4", lambda sources, dest, *a, **k: f"join {_name(dest)}"),
    (Writer, "write", lambda self, *a, **k: "bag message"),
    (Writer, "close", lambda self, *a, **k: "bag close"),
]


@contextmanager
def inject(faults: Faults) -> Iterator[Faults]:
    """Patch every target so that it consults `faults` first; restore them all on exit."""
    saved: list[tuple[Any, str, Any]] = []

    def wrap(real: Callable[..., Any], label: Callable[..., str]) -> Callable[..., Any]:
        def call(*args: Any, **kwargs: Any) -> Any:
            faults.check(label(*args, **kwargs))
            return real(*args, **kwargs)

        return call

    try:
        for owner, attr, label in TARGETS:
            real = getattr(owner, attr)
            saved.append((owner, attr, real))
            setattr(owner, attr, wrap(real, label))
        yield faults
    finally:
        for owner, attr, real in reversed(saved):
            setattr(owner, attr, real)
