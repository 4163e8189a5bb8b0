"""A job for the local executor that reports and returns what its worker process looks like (signals)."""

from __future__ import annotations

import os
import signal
import time
from dataclasses import dataclass

from openral_data.runtime.parallel.channel import report


@dataclass(frozen=True)
class Probe:
    job: int
    pid: int
    blocked_at_start: frozenset[int]  # signals the worker held blocked when its initializer ran
    blocked: frozenset[int]  # signals the worker holds blocked while it runs its job
    sigint_ignored: bool
    finished_at: float


_at_start: set[int] = set()


def init_probe() -> None:
    """The initializer: ignore SIGINT as the real ones do, and note which signals are blocked meanwhile."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _at_start.update(_blocked())


def probe(job: int) -> Probe:
    report(("running", job))
    ignored = signal.getsignal(signal.SIGINT) == signal.SIG_IGN
    return Probe(job, os.getpid(), frozenset(_at_start), _blocked(), ignored, time.time())


def _blocked() -> frozenset[int]:
    return frozenset(int(s) for s in signal.pthread_sigmask(signal.SIG_BLOCK, []))
