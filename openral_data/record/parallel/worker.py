"""One worker: a plain `record` of its share of the seeds, in its own process with its own simulator."""

from __future__ import annotations

import os
import signal
import time
from dataclasses import dataclass

from openral_data.record.parallel.plan import WorkerJob
from openral_data.record.session import EARLY_STOP
from openral_data.types import EpisodeRecord


@dataclass(frozen=True)
class WorkerResult:
    worker: int
    episodes: list[EpisodeRecord]
    frames: int
    seconds: float
    finished_at: float  # time.time() when the worker's dataset was complete
    pid: int
    discarded: int = 0  # episodes it did not keep (`keep="success"`)


def init_local_worker() -> None:
    """Process-pool initializer: the parent coordinates stopping. Ctrl-C is left to the parent, which sends its
    workers SIGTERM; a SIGTERM that arrives before the recording starts is remembered rather than killing the
    process mid-start (a pool whose worker dies that way hangs in shutdown): before `record` starts, the worker
    does not start it; while `record` builds its scene, its episode loop starts already stopped
    (`session.EARLY_STOP`). During the recording, `record`'s own handlers stop it at the next step boundary."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _remember_stop)


def _remember_stop(signum: int, frame: object) -> None:
    EARLY_STOP.set()


def run_worker(job: WorkerJob) -> WorkerResult:
    if job.threads is not None:
        # llvmpipe reads this when the first GL context is made, i.e. inside record()
        os.environ["LP_NUM_THREADS"] = str(job.threads)
    from openral_data.record.sim import record

    if EARLY_STOP.is_set():
        raise KeyboardInterrupt
    summary = record(job.opts)
    return WorkerResult(
        job.worker, summary.episodes, summary.frames, summary.seconds, time.time(), os.getpid(), summary.discarded
    )
