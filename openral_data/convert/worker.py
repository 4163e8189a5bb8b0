"""One worker of `convert --workers`: a plain `convert_bags` of its block of bags, in its own process.

Kept apart from convert/parallel.py so that a worker process imports only the conversion (it is started by
unpickling `run_convert_job`), not the executors and the merge. In a local pool it reports its progress (the
mapped messages read, as one process's bar counts them) to the parent as it goes.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from openral_data.convert.preflight import CameraTopics
from openral_data.convert.summary import ConvertSummary
from openral_data.convert.to_lerobot import convert_bags
from openral_data.formats.codec import Codec
from openral_data.runtime.parallel.channel import report
from openral_data.schemas.mapping import Mapping


@dataclass(frozen=True)
class ConvertJob:
    worker: int
    src: Path  # the source as the user named it (recorded in the dataset's metadata)
    bags: list[Path]  # this worker's block, in bag order
    dst: Path  # the worker's own dataset
    mapping: Mapping
    codec: Codec
    cameras: CameraTopics  # depth units and intrinsics, as found over all the bags
    carried_task: tuple[int, str] | None  # the task text the block's first bag starts with (one process's carry)


@dataclass(frozen=True)
class ConvertResult:
    worker: int
    summary: ConvertSummary
    finished_at: float
    pid: int
    messages: int  # mapped messages the block read (its share of the progress total)


@dataclass(frozen=True)
class ConvertProgress:
    """What a running worker reports to the parent (local pools only, see `channel.report`)."""

    worker: int
    messages: int  # mapped messages read so far in this worker's block


_running = threading.Event()
_stop_requested = threading.Event()


def init_convert_worker() -> None:
    """Process-pool initializer: Ctrl-C is the parent's; the parent's SIGTERM (another worker failed) stops a
    running conversion (its staging folder is discarded) and an idle worker just remembers it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _on_sigterm)


def _on_sigterm(signum: int, frame: object) -> None:
    _stop_requested.set()
    if _running.is_set():
        raise KeyboardInterrupt


def run_convert_job(job: ConvertJob) -> ConvertResult:
    if _stop_requested.is_set():
        raise KeyboardInterrupt
    total = 0

    def progress(done: int, messages: int) -> None:
        nonlocal total
        total = messages
        report(ConvertProgress(job.worker, done))

    _running.set()
    try:
        summary = convert_bags(
            job.src,
            job.dst,
            job.mapping,
            codec=job.codec,
            progress=progress,
            bags=job.bags,
            checks=False,
            cameras=job.cameras,
            carried_task=job.carried_task,
        )
    finally:
        _running.clear()
    return ConvertResult(job.worker, summary, time.time(), os.getpid(), total)
