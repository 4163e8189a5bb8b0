"""The frame around an episode loop, shared by `record` and `record --hal`: stop requests, and what an
interrupted or failed loop leaves behind (the episode in flight discarded, every finished one kept)."""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from openral_data.errors import DiskError, OpenralError, disk_class, disk_errno
from openral_data.policies.base import PolicyAdapter
from openral_data.runtime.bridge import DatasetBridge

# A stop asked for before any episode loop's handlers were in place: a `--workers` worker's SIGTERM that arrived
# while its scene was still being built (record/parallel/worker.py sets it). The next StopRequest starts with it.
EARLY_STOP = threading.Event()


class StopRequest:
    """Ctrl-C / SIGTERM ask the recording to stop at the next step boundary, never inside a commit.

    The loop then raises KeyboardInterrupt where nothing is half-written: the episode in flight is discarded
    and every finished one stays. A second Ctrl-C interrupts at once. A stop that came before the handlers were
    installed (`EARLY_STOP`) counts as already requested.
    """

    def __init__(self) -> None:
        self._requested = False
        self._previous: dict[int, object] = {}
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self._previous[sig] = signal.signal(sig, self._handle)
        self._requested = self._requested or EARLY_STOP.is_set()

    def _handle(self, signum: int, frame: object) -> None:
        if self._requested and signum == signal.SIGINT:
            raise KeyboardInterrupt
        self._requested = True

    def check(self) -> None:
        if self._requested:
            raise KeyboardInterrupt

    def restore(self) -> None:
        for sig, handler in self._previous.items():
            signal.signal(sig, handler)  # type: ignore[arg-type]
        self._previous.clear()


@contextmanager
def episode_loop(
    bridge: DatasetBridge, policy: PolicyAdapter, out: Path, finished: Callable[[], int]
) -> Iterator[StopRequest]:
    """Run an episode loop under a StopRequest; close the bridge and the policy however it ends.

    On an error the bridge is closed first (discarding the episode in flight; finished episodes are already
    durable); an error while closing after that is not reported over the first one. An OpenralError names the
    `finished()` episodes kept in `out`; a disk problem (`DiskError`, or an OSError with ENOSPC, EIO, EROFS or
    EDQUOT) ends the run with one line naming it and the episodes kept.
    """
    stop = StopRequest()
    try:
        try:
            yield stop
        except BaseException as exc:
            with contextlib.suppress(Exception):  # the disk that failed the loop usually fails closing too
                bridge.close()
            explained = ended_by(exc, out, finished())
            if explained is None:
                raise
            raise explained from exc
    finally:
        stop.restore()
        policy.close()
    try:
        bridge.close()
    except Exception as exc:
        explained = ended_by(exc, out, finished())
        if explained is None:
            raise
        raise explained from exc


def ended_by(exc: BaseException, out: Path, kept: int) -> OpenralError | None:
    """The one-line error that ends a recording on `exc`, naming the episodes kept; None: re-raise `exc`."""
    problem = disk_errno(exc)
    if problem is not None:
        committed = isinstance(exc, DiskError) and exc.committed
        doing = exc.doing if isinstance(exc, DiskError) else f"recording episode {kept}"
        err = disk_class(exc)(out, problem, doing, committed=committed)  # (over the spill cap: `SpillFull`)
        if committed:  # the journal is durable: recovery finishes this episode's commit
            note = f"{_episodes(kept + 1)} kept (free space, then record --resume finishes episode {kept}'s commit)"
        else:
            note = f"{_episodes(kept)} kept (free space, then record --resume)"
        return err.amended(f"{err}; {note}")
    if isinstance(exc, OpenralError) and kept:
        return exc.amended(f"{exc} ({kept} finished episode(s) kept in {out})")
    return None


def _episodes(n: int) -> str:
    if n == 0:
        return "no episode is"
    return "episode 0 is" if n == 1 else f"episodes 0-{n - 1} are"
