"""One worker: a plain `record` of its share of the seeds, in its own process with its own simulator."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

from openral_data.parallel.plan import WorkerJob
from openral_data.sinks.base import EpisodeRecord


@dataclass(frozen=True)
class WorkerResult:
    worker: int
    episodes: list[EpisodeRecord]
    frames: int
    seconds: float
    finished_at: float  # time.time() when the worker's dataset was complete
    pid: int


def run_worker(job: WorkerJob) -> WorkerResult:
    if job.threads is not None:
        # llvmpipe reads this when the first GL context is made, i.e. inside record()
        os.environ["LP_NUM_THREADS"] = str(job.threads)
    from openral_data.record import record

    summary = record(job.opts)
    return WorkerResult(job.worker, summary.episodes, summary.frames, summary.seconds, time.time(), os.getpid())
