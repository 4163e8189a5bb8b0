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
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from openral_data.convert.from_arrays import convert_arrays
from openral_data.convert.preflight import CameraTopics
from openral_data.convert.summary import ConvertSummary
from openral_data.convert.to_lerobot import convert_bags
from openral_data.errors import DatasetError
from openral_data.formats.episodic import ArraySource
from openral_data.formats.lerobot_v3.encoder import VideoSettings
from openral_data.runtime.parallel.channel import report
from openral_data.schemas.mapping import Mapping


@dataclass(frozen=True)
class ConvertJob:
    worker: int
    src: Path  # the source as the user named it (recorded in the dataset's metadata)
    bags: list[Path]  # this worker's block, in bag order
    dst: Path  # the worker's own dataset
    mapping: Mapping
    video: VideoSettings  # resolved in the parent: a worker never probes `auto` again
    cameras: CameraTopics  # depth units and intrinsics, as found over all the bags
    carried_task: tuple[int, str] | None  # the task text the block's first bag starts with (one process's carry)


Reopen = Callable[[Path, list[Path]], ArraySource | None]  # a source kind's `open_block` (pickled by reference)


@dataclass(frozen=True)
class ArrayJob:
    """A block of an array source's files (`convert --workers` over HDF5 files, RLDS shards, a Zarr store)."""

    worker: int
    src: Path  # the source as the user named it
    layout: str
    files: list[Path]  # this worker's block, in source order
    dst: Path
    mapping: Mapping
    video: VideoSettings  # resolved in the parent
    reopen: Reopen  # the part of `src` that `files` hold, as its kind opens it


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


def run_convert_job(job: ConvertJob | ArrayJob) -> ConvertResult:
    if _stop_requested.is_set():
        raise KeyboardInterrupt
    total = 0

    def progress(done: int, messages: int) -> None:
        nonlocal total
        total = messages
        report(ConvertProgress(job.worker, done))

    _running.set()
    try:
        if isinstance(job, ArrayJob):
            return _run_array_job(job, progress)
        summary = convert_bags(
            job.src,
            job.dst,
            job.mapping,
            video=job.video,
            progress=progress,
            bags=job.bags,
            checks=False,
            cameras=job.cameras,
            carried_task=job.carried_task,
        )
    finally:
        _running.clear()
    return ConvertResult(job.worker, summary, time.time(), os.getpid(), total)


def _run_array_job(job: ArrayJob, progress: Callable[[int, int], None]) -> ConvertResult:
    source = job.reopen(job.src, job.files)
    if source is None:
        raise DatasetError(f"{job.src}: no longer a {job.layout} source", code="dataset.source.layout")
    steps = 0

    def counted(done: int, total: int) -> None:
        nonlocal steps
        steps = done
        progress(done, total)

    summary = convert_arrays(source, job.dst, job.mapping, video=job.video, progress=counted, checks=False)
    return ConvertResult(job.worker, summary, time.time(), os.getpid(), steps)
