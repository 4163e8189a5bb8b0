"""`convert SRC_DIR DST --workers N [--executor local|ray]`: a folder of bags converted in N processes.

The bags (in `find_bags`' order, the order a one-process convert reads them) are split into at most N contiguous
blocks; each worker (convert/worker.py) converts its block with `convert_bags` into its own dataset under a
hidden sibling of DST (``.DST.workers-PID``, as `record --workers`), on the executors `record --workers` uses.
The blocks are then merged in bag order with the merge `record --workers` and `episodes merge` use
(`edit.ops.write_selection`: rows re-indexed, videos remuxed, no re-encode; camera statistics from the summed
histograms, so exact), each episode's `source_episode` (its seed) renumbered as one process numbers it.
DST appears complete or not at all; so does an interrupted run (Ctrl-C stops the workers, whose staging folders
go with the workers' folder). Progress is counted as one process counts it (mapped messages read): each worker
reports its own count as it goes (local pools; under Ray a block counts when it has finished).

With a `task_topic`, one process carries a bag's last task message into the next bag's first frames: each block
starts with the last task message of the bags before it (read from their task topic up front), so it does too.
"""

from __future__ import annotations

import dataclasses
import shutil
import time
from pathlib import Path

from openral_data.convert.preflight import CameraTopics, check_bags, check_outcome, last_task
from openral_data.convert.sources import find_bags
from openral_data.convert.summary import ConvertSummary, TopicReport
from openral_data.convert.to_lerobot import ProgressFn
from openral_data.convert.worker import (
    ArrayJob,
    ConvertJob,
    ConvertProgress,
    ConvertResult,
    Reopen,
    init_convert_worker,
    run_convert_job,
)
from openral_data.edit.source import EpisodeData, SourceDataset
from openral_data.formats.codec import Codec
from openral_data.formats.episodic import ArraySource
from openral_data.formats.lerobot_v3.encoder import VideoSettings
from openral_data.formats.staging import check_new_output
from openral_data.runtime.parallel.channel import STOP_HELD, held
from openral_data.runtime.parallel.choice import contiguous_blocks
from openral_data.runtime.parallel.executors import check_executor, run_on
from openral_data.runtime.parallel.shards import merge_shards
from openral_data.runtime.parallel.workdir import fresh_workers_dir, worker_dir
from openral_data.schemas.mapping import Mapping
from openral_data.types import EpisodeRecord


def plan_blocks(bags: list[Path], workers: int) -> list[list[Path]]:
    """At most `workers` contiguous, near-equal blocks of `bags` (or an array source's files), in order."""
    return [bags[r.start : r.stop] for r in contiguous_blocks(len(bags), workers)]


def carried_tasks(blocks: list[list[Path]], mapping: Mapping) -> list[tuple[int, str] | None]:
    """The task each block starts with: the last task message of the bags before it, as one process carries it
    from bag to bag (only with a `task_topic`; reads that topic of every bag but the last block's)."""
    carry: tuple[int, str] | None = None
    carried: list[tuple[int, str] | None] = []
    for block in blocks:
        carried.append(carry)
        if block is blocks[-1] or mapping.task_topic is None or mapping.task is not None:
            continue
        for bag in block:
            carry = last_task(bag, mapping) or carry
    return carried


def convert_parallel(
    src: Path,
    dst: Path,
    mapping: Mapping,
    workers: int,
    *,
    executor: str = "local",
    address: str | None = None,
    codec: Codec = "av1",
    progress: ProgressFn | None = None,
    video: VideoSettings | None = None,
) -> ConvertSummary:
    """Convert the bags of `src` in `workers` processes into one dataset at `dst`, as `convert_bags` would."""
    settings = VideoSettings.given(codec, video=video)
    check_executor(executor, address)
    bags = find_bags(src)
    blocks = plan_blocks(bags, workers)
    cameras = CameraTopics()
    totals = check_bags(bags, mapping, ConvertSummary(src=src, dst=dst), cameras)  # every bag, before any work
    workdir = fresh_workdir(dst)
    jobs: list[ConvertJob | ArrayJob] = [
        ConvertJob(w, src, block, worker_dir(workdir, w), mapping, settings, cameras, carry)
        for w, (block, carry) in enumerate(zip(blocks, carried_tasks(blocks, mapping), strict=True))
    ]
    return _run_blocks(jobs, workdir, src, dst, totals, executor, address, progress)


def fresh_workdir(dst: Path) -> Path:
    """DST checked new (or empty), and the hidden folder beside it where the workers write their blocks, emptied
    of what a killed run left."""
    check_new_output(dst, "DST")
    dst.parent.mkdir(parents=True, exist_ok=True)
    return fresh_workers_dir(dst)


def _run_blocks(
    jobs: list[ConvertJob | ArrayJob],
    workdir: Path,
    src: Path,
    dst: Path,
    totals: int,
    executor: str,
    address: str | None,
    progress: ProgressFn | None,
    layout: str | None = None,
) -> ConvertSummary:
    """The jobs on the executor, their summaries combined and their datasets merged in order into `dst`
    (`layout`: an array source's, None for bags); the workers' folder goes in any case."""
    t0 = time.perf_counter()
    bar = _Progress(len(jobs), totals, progress)
    try:
        workdir.mkdir()
        bar.show()
        finished = run_on(
            jobs,
            run_convert_job,
            executor,
            address,
            initializer=init_convert_worker,
            on_finished=bar.finished,
            on_report=bar.reported,
        )
        results = sorted(finished, key=lambda r: r.worker)
        summary = _combine(src, dst, [r.summary for r in results])
        summary.source_kind = layout
        check_outcome(summary)
        _merge(results, dst)
    finally:
        with held(STOP_HELD):
            shutil.rmtree(workdir, ignore_errors=True)
    summary.seconds = time.perf_counter() - t0
    return summary


def convert_arrays_parallel(
    source: ArraySource,
    dst: Path,
    mapping: Mapping,
    workers: int,
    *,
    executor: str = "local",
    address: str | None = None,
    codec: Codec = "av1",
    progress: ProgressFn | None = None,
    video: VideoSettings | None = None,
    files: list[Path],
    reopen: Reopen,
) -> ConvertSummary:
    """An array source's `files` (its kind's blocks: HDF5 files, RLDS shards; a Zarr store is one block) in
    `workers` processes (contiguous blocks of files, as bags), merged in file order into one dataset at `dst`, as
    `convert_arrays` would write it; each worker opens its block with `reopen(source.path, block)` (its kind's
    `open_block`)."""
    settings = VideoSettings.given(codec, video=video)
    check_executor(executor, address)
    totals = sum(ep.length for ep in source.episodes())  # every file opened once, before any work
    source.close()
    workdir = fresh_workdir(dst)
    jobs: list[ConvertJob | ArrayJob] = [
        ArrayJob(w, source.path, source.layout, block, worker_dir(workdir, w), mapping, settings, reopen)
        for w, block in enumerate(plan_blocks(files, workers))
    ]
    return _run_blocks(jobs, workdir, source.path, dst, totals, executor, address, progress, source.layout)


class _Progress:
    """One process's progress (mapped messages read, of `totals`) summed over the workers: each worker's count
    as it reports it (local pools) and its block's whole count when its result comes back (any executor).
    `progress` is called only when the sum grew, so it sees increasing values, the last one `totals`."""

    def __init__(self, workers: int, totals: int, progress: ProgressFn | None) -> None:
        self.done = [0] * workers
        self.totals = totals
        self.progress = progress
        self.shown = -1

    def reported(self, item: object) -> None:
        if isinstance(item, ConvertProgress):
            self.done[item.worker] = max(self.done[item.worker], item.messages)
            self.show()

    def finished(self, result: ConvertResult) -> None:
        self.done[result.worker] = max(self.done[result.worker], result.messages)
        self.show()

    def show(self) -> None:
        now = sum(self.done)
        if self.progress is not None and now > self.shown:
            self.shown = now
            self.progress(now, self.totals)


def _combine(src: Path, dst: Path, parts: list[ConvertSummary]) -> ConvertSummary:
    """The blocks' summaries as one process's: counts summed, episodes and source episodes numbered on."""
    total = ConvertSummary(src=src, dst=dst)
    for part in parts:
        total.bags += part.bags
        for e in part.episodes:
            seed = None if e.seed is None else e.seed + total.source_episodes
            total.episodes.append(EpisodeRecord(len(total.episodes), e.length, e.success, seed))
        total.frames += part.frames
        total.source_episodes += part.source_episodes
        for topic, rep in part.topics.items():
            mine = total.topics.setdefault(topic, TopicReport(topic, rep.msgtype))
            mine.messages += rep.messages
            mine.used += rep.used
            mine.unused += rep.unused
            mine.unfillable_frames += rep.unfillable_frames
        for name in ("skipped_topics", "header_stamps", "zero_stamps", "trailing_bytes"):
            counts: dict[str, int] = getattr(total, name)
            for key, n in getattr(part, name).items():
                counts[key] = counts.get(key, 0) + n
        total.unfillable_frames += part.unfillable_frames
        total.splits += part.splits
        total.empty_segments += part.empty_segments
        total.late_messages += part.late_messages
    return total


def _merge(results: list[ConvertResult], dst: Path) -> None:
    """The workers' datasets, in bag order, as one dataset at `dst` (exact stats, videos remuxed)."""
    sources: list[SourceDataset] = []
    offsets: dict[Path, int] = {}  # a worker's dataset -> source episodes of the blocks before it
    before = 0
    for r in results:
        if r.summary.episodes:
            src = SourceDataset(r.summary.dst)
            sources.append(src)
            offsets[src.root] = before
        before += r.summary.source_episodes

    def renumber(ep: EpisodeData) -> EpisodeData:
        if ep.seed is None:
            return ep
        seed = ep.seed + offsets[ep.source]
        return dataclasses.replace(ep, seed=seed, initial_state={**ep.initial_state, "source_episode": seed})

    merge_shards(sources, dst, "convert --workers", where=dst, transform=renumber)
