"""Which seeds each worker records: contiguous blocks, so a worker's share is one plain `record` run."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

from openral_data.errors import UsageError
from openral_data.record.options import RecordOptions
from openral_data.runtime import registry
from openral_data.runtime.parallel.choice import check_workers, contiguous_blocks
from openral_data.runtime.parallel.workdir import worker_dir
from openral_data.schemas.scene import load_recordable_scene


@dataclass(frozen=True)
class WorkerJob:
    worker: int
    opts: RecordOptions  # out = the worker's own folder; seed/n_episodes/first_episode = its share
    threads: int | None = None  # per-process thread budget for the renderer (LP_NUM_THREADS), None: leave as is


def resolve_counts(opts: RecordOptions) -> tuple[int, int]:
    """(n_episodes, first seed) as `record` will resolve them from the options and the scene."""
    scene = load_recordable_scene(registry.resolve_scene_path(opts.scene))
    n = opts.n_episodes if opts.n_episodes is not None else scene.n_episodes
    seed = opts.seed if opts.seed is not None else scene.seed
    if n < 1:
        raise UsageError(f"--n-episodes must be >= 1, got {n}")
    if seed < 0:
        raise UsageError(f"--seed must be >= 0, got {seed}")
    return n, seed


def plan(opts: RecordOptions, workers: int, workdir: Path, threads: int | None = None) -> list[WorkerJob]:
    """Split episodes 0..n-1 (seeds seed..seed+n-1) into at most `workers` contiguous, near-equal blocks; with a
    `keep_target` (n: the attempts' cap) each block keeps its near-equal share of the target."""
    check_workers(workers)
    n, seed = resolve_counts(opts)
    jobs: list[WorkerJob] = []
    blocks = contiguous_blocks(n, workers)
    targets = [len(b) for b in contiguous_blocks(opts.keep_target, len(blocks))] if opts.keep_target else []
    for w, block in enumerate(blocks):
        share = dataclasses.replace(
            opts,
            out=worker_dir(workdir, w),
            seed=seed + block.start,
            n_episodes=len(block),
            first_episode=block.start,
            keep_target=(targets[w] if w < len(targets) else 0) if opts.keep_target else None,
            check_first=False,  # the merged dataset is checked when it is published (formats/staging)
        )
        jobs.append(WorkerJob(w, share, threads))
    return jobs
