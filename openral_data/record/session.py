"""The frame around an episode loop, shared by `record` and `record --hal`: stop requests, and what an
interrupted or failed loop leaves behind (the episode in flight discarded, every finished one kept)."""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from openral_data.errors import OpenralError
from openral_data.policies.base import PolicyAdapter
from openral_data.record.bridge import DatasetBridge


class StopRequest:
    """Ctrl-C / SIGTERM ask the recording to stop at the next step boundary, never inside a commit.

    The loop then raises KeyboardInterrupt where nothing is half-written: the episode in flight is discarded
    and every finished one stays. A second Ctrl-C interrupts at once.
    """

    def __init__(self) -> None:
        self._requested = False
        self._previous: dict[int, object] = {}
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self._previous[sig] = signal.signal(sig, self._handle)

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
    durable), and an OpenralError names the `finished()` episodes kept in `out`.
    """
    stop = StopRequest()
    try:
        yield stop
    except BaseException as exc:
        bridge.close()
        kept = finished()
        if isinstance(exc, OpenralError) and kept:
            raise exc.amended(f"{exc} ({kept} finished episode(s) kept in {out})") from None
        raise
    finally:
        stop.restore()
        policy.close()
    bridge.close()
