"""Signals and reports around a pool of workers: a worker's start, its report channel to the parent, and the
signals a parent holds while it starts or stops its workers.

Kept apart from executors.py so that a worker process, which imports this module to run `start_worker`, does
not import the executors (nor what they import). Under Ray there is no channel: `report` does nothing there, and
the parent hears of a job only when it has finished.
"""

from __future__ import annotations

import contextlib
import signal
from collections.abc import Callable, Iterator
from multiprocessing.queues import SimpleQueue
from typing import Any

# held (blocked) by the parent while it starts a worker (the mask is inherited across fork and exec), so a Ctrl-C
# or SIGTERM that arrives before the worker's initializer installed its handlers waits for them instead of
# killing the half-started process (a traceback, and a pool that breaks)
START_HELD = frozenset({signal.SIGINT, signal.SIGTERM})
STOP_HELD = frozenset({signal.SIGINT})  # held by the parent while it stops its workers (see `held`)

_reports: list[SimpleQueue[Any]] = []  # this worker's channel to the parent, if it has one


def start_worker(initializer: Callable[[], None], reports: SimpleQueue[Any] | None) -> None:
    """Process-pool initializer: the job's own initializer (its signal handlers), then the signals the parent
    held blocked for the start are let through; `reports` is where `report` sends."""
    _reports[:] = [] if reports is None else [reports]
    initializer()
    signal.pthread_sigmask(signal.SIG_UNBLOCK, START_HELD)


def report(item: Any) -> None:
    """Send `item` (picklable, small) to the parent's `on_report`; nothing when the parent asked for no reports
    or the job runs outside a local pool (Ray)."""
    for channel in _reports:
        channel.put(item)


@contextlib.contextmanager
def held(signals: frozenset[signal.Signals]) -> Iterator[None]:
    """Hold `signals` blocked in this thread; one that arrived meanwhile is delivered on leaving. A parent holds
    SIGINT while it stops its workers and removes their folders: a second Ctrl-C then waits for that clean-up
    instead of cutting it short (a pool shut down half-way hangs the process at exit, a folder half removed
    stays)."""
    old = signal.pthread_sigmask(signal.SIG_BLOCK, signals)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
