"""Frames spilled to disk behind a camera's encoder (video.py), written by a thread of their own.

A real-time recording's loop hands a frame the encoder's queue has no room for to its camera's `SpillWriter`: the
loop only queues it (no file is opened on the control thread) and the writer thread saves it raw (`.npy`) into
the staging folder beside the episode's mp4. The frame stays in memory until its file is complete: the encoder,
reaching a frame not yet on disk, takes it from memory (the writer then deletes the file, or never writes it),
else reads the file back and deletes it. Frames keep their order (the encoder's queue holds each one's place)
and memory stays bounded: at most `capacity` frames wait for the spill writer. When those are full too (the disk
is slower than the camera and the encoder slower still), `EncoderWorker.put` waits for a place in either queue:
the wait is counted (`waits`, the loop's overruns) and nothing is dropped or held beyond the bound.

`SpillBudget` caps the spilled bytes on disk at once, shared by a writer's cameras (`WriterConfig.spill_limit_mb`;
default: half the free space of the dataset's disk when the writer opens). A spill the cap or the disk refuses
(ENOSPC, EIO, ...) fails the episode being recorded with one `DiskError` (``write.disk``; over the cap
`SpillFull`, ``write.disk.spill``): the next `put` raises it (or the next `begin`, when the episode had ended:
its frames were all still in memory, so it is complete) and committed episodes are untouched.
"""

from __future__ import annotations

import contextlib
import errno
import logging
import queue
import shutil
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from openral_data.errors import SpillFull, WriteError
from openral_data.formats.write_errors import write_error

MB = 1 << 20
FREE_SHARE = 0.5  # the default cap: this share of the dataset disk's free space
HEADER = 128  # bytes a `.npy` header takes (numpy pads it to 64-byte multiples; 128 for a small shape)

log = logging.getLogger(__name__)


class SpillBudget:
    """Bytes of spilled frames on disk at once, at most `limit`; shared by the cameras of one writer."""

    def __init__(self, limit: int) -> None:
        self.limit = limit
        self._used = 0
        self._lock = threading.Lock()

    @classmethod
    def for_root(cls, root: Path, limit_mb: float | None) -> SpillBudget:
        """`limit_mb` MB, or (None) `FREE_SHARE` of the free space of the disk holding `root`."""
        if limit_mb is not None:
            return cls(int(limit_mb * MB))
        return cls(int(shutil.disk_usage(root).free * FREE_SHARE))

    def take(self, size: int) -> bool:
        with self._lock:
            if self._used + size > self.limit:
                return False
            self._used += size
            return True

    def give(self, size: int) -> None:
        with self._lock:
            self._used -= size


@dataclass(eq=False)
class Spilled:
    """A frame handed to the spill writer: in memory (`frame`) until its file at `path` is complete."""

    path: Path
    frame: npt.NDArray[Any] | None
    size: int
    taken: bool = False  # the encoder took the frame from memory
    on_disk: bool = False  # the file is complete (and counted in the budget)
    done: threading.Event = field(default_factory=threading.Event)


_STOP = object()


class SpillWriter:
    """One camera's spill thread (module docstring). `error`: the first spill the disk or the cap refused."""

    def __init__(self, name: str, budget: SpillBudget, capacity: int) -> None:
        self.name = name
        self.budget = budget
        self.error: WriteError | None = None
        self._q: queue.SimpleQueue[object] = queue.SimpleQueue()
        self._slots = threading.Semaphore(max(1, capacity))  # one per frame waiting in memory to be written
        self._lock = threading.Lock()
        self._said = False  # the first frame this camera spilled was said (once a writer: `_say_once`)
        self._thread = threading.Thread(target=self._run, name=f"spill-{name}", daemon=True)
        self._thread.start()

    # -- producer side -------------------------------------------------------------------------------
    def reserve(self, timeout: float | None = None) -> bool:
        """A place for one more frame waiting to be written (False: none within `timeout` seconds)."""
        if timeout is None:
            return self._slots.acquire(blocking=False)
        return self._slots.acquire(timeout=timeout)

    def submit(self, path: Path, frame: npt.NDArray[Any]) -> Spilled:
        """Queue `frame` (a place `reserve`d) for writing to `path`; the encoder queues the returned item."""
        item = Spilled(path, frame, frame.nbytes + HEADER)
        self._q.put(item)
        return item

    def close(self) -> None:
        self._q.put(_STOP)
        self._thread.join()

    # -- encoder side --------------------------------------------------------------------------------
    def claim(self, item: Spilled) -> npt.NDArray[Any]:
        """The frame: from memory while its file is not complete, else read back from the file (deleted)."""
        with self._lock:
            frame = item.frame
            if frame is not None:
                item.frame, item.taken = None, True
                self._slots.release()
                return frame
        item.done.wait()  # on disk: complete, since the frame left memory
        with open(item.path, "rb") as fh:
            image: npt.NDArray[Any] = np.load(fh, allow_pickle=False)
        self._drop(item)
        return image

    def _drop(self, item: Spilled) -> None:
        item.path.unlink(missing_ok=True)
        if item.on_disk:
            self.budget.give(item.size)

    # -- spill thread --------------------------------------------------------------------------------
    def _run(self) -> None:
        while (item := self._q.get()) is not _STOP:
            assert isinstance(item, Spilled)
            self._write(item)

    def _write(self, item: Spilled) -> None:
        with self._lock:
            frame = item.frame
        if frame is None or self.error is not None:  # taken already; or the disk refused: the encoder takes it
            item.done.set()
            return
        failure: OSError | WriteError | None = None
        try:
            self._save(item, frame)
        except (OSError, WriteError) as exc:
            failure = exc
        kept = False
        with self._lock:
            if item.taken:  # the encoder took it meanwhile: the file is not needed (nor a failure to write it)
                self._drop(item)
                with contextlib.suppress(OSError):
                    item.path.parent.rmdir()  # the episode may have ended meanwhile: its folder goes
            elif failure is None:
                item.frame = None  # its file is complete: the memory goes
                self._slots.release()
                kept = True
            else:  # the frame stays in memory for the encoder; the episode fails (`error`)
                self._drop(item)
                item.on_disk = False
                self.error = self._refused(item, failure)
        item.done.set()
        if kept:
            self._say_once()  # outside the lock: the encoder's `claim` never waits on a log handler

    def _say_once(self) -> None:
        """Warn, on this thread (never the loop's), the first time this camera's frames go to disk: the operator
        learns while recording that its encoder is behind, not from the session's summary."""
        if not self._said:
            self._said = True
            log.warning(
                "camera %s: its encoder cannot keep up; frames spill to disk and are encoded behind (nothing is "
                "lost: each episode commits once its video is complete; `stats` counts the spills per episode)",
                self.name,
            )

    def _refused(self, item: Spilled, failure: OSError | WriteError) -> WriteError:
        if isinstance(failure, WriteError):
            return failure
        return write_error(item.path.parent, failure, f"spilling camera {self.name}'s frames")

    def _save(self, item: Spilled, frame: npt.NDArray[Any]) -> None:
        if not self.budget.take(item.size):
            cap = f"{self.budget.limit / MB:.2f} MB"
            raise SpillFull(
                item.path.parent,
                errno.ENOSPC,
                f"spilling camera {self.name}'s frames: over the spill cap of {cap} (WriterConfig.spill_limit_mb)",
            )
        item.on_disk = True
        item.path.parent.mkdir(parents=True, exist_ok=True)
        with open(item.path, "wb") as fh:
            np.save(fh, frame, allow_pickle=False)
