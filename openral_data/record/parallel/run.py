"""`record --workers N`: plan seed blocks, run them (local processes or Ray), merge into one dataset by seed.

Every worker records its share into its own folder under a hidden sibling of `--out` (``.OUT.workers-PID``).
The LeRobot datasets are then merged episode by episode in seed order (`edit.ops.write_selection`: rows
re-indexed, packets remuxed, no re-encode); MCAP bags were already named with their final episode numbers by
the workers and are moved under ``mcap/``. The output folder appears complete (rename) or not at all, and its
content does not depend on which worker finished first.
"""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

from openral_data.edit.source import SourceDataset
from openral_data.errors import ExecutorError, OpenralError, UsageError
from openral_data.formats import atomic
from openral_data.formats.jsonfile import parse_json
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.mcap import MCAP_SUBDIR, finished_bags
from openral_data.formats.staging import Staging
from openral_data.record.options import RecordOptions, RecordSummary, default_out, rskill_ref
from openral_data.record.output import Claim, claim
from openral_data.record.parallel.plan import plan
from openral_data.record.parallel.worker import WorkerResult, init_local_worker, run_worker
from openral_data.runtime import registry
from openral_data.runtime.parallel.executors import run_on
from openral_data.runtime.parallel.shards import merge_shards
from openral_data.runtime.parallel.workdir import fresh_workers_dir, kept_worker_episodes, worker_dir
from openral_data.schemas.scene import load_recordable_scene
from openral_data.types import EpisodeRecord


@dataclass(frozen=True)
class ParallelSummary(RecordSummary):
    finish_order: tuple[int, ...] = ()  # worker ids in the order they finished (for reports and tests)
    workers: int = 1


def record_parallel(
    opts: RecordOptions,
    workers: int,
    executor: str = "local",
    address: str | None = None,
    threads: int | None = None,
) -> ParallelSummary:
    if opts.resume:
        raise UsageError("--resume: continue a recording with one process (no --workers/--executor)")
    if opts.save_video or opts.save_video_dir is not None:
        raise UsageError("--save-video: record with one process (no --workers/--executor) to get debug videos")
    if opts.view:
        raise UsageError("--view: watch a recording made by one process (no --workers/--executor)")
    if opts.keep == "success" and "mcap" in opts.formats:
        raise UsageError("--keep success: the MCAP bags of several workers are numbered in advance; use one process")
    if opts.out is None:
        scene = load_recordable_scene(registry.resolve_scene_path(opts.scene))
        rskill = registry.resolve_rskill(rskill_ref(opts.rskill, scene))[0]
        opts = dataclasses.replace(opts, out=default_out(scene, rskill.id))
    out = opts.out
    assert out is not None
    out.parent.mkdir(parents=True, exist_ok=True)
    held = claim(out, "openral-data record --workers", resume=False)  # before anything goes into `out`
    workdir = fresh_workers_dir(out)
    t0 = time.perf_counter()
    try:
        jobs = plan(opts, workers, workdir, threads)
        results = run_on(jobs, run_worker, executor, address, initializer=init_local_worker)
        episodes = _assemble(results, workdir, held, opts.formats)
    except BaseException as exc:
        held.release()  # (a no-op once `_assemble` let go of it for the rename)
        # lose nothing: what the workers finished stays in their own (complete, durable) datasets
        kept = kept_worker_episodes(workdir)
        if not kept:
            shutil.rmtree(workdir, ignore_errors=True)
        elif isinstance(exc, OpenralError):
            raise exc.amended(f"{exc} ({kept_note(workdir, kept)})") from None
        raise
    shutil.rmtree(workdir, ignore_errors=True)
    return ParallelSummary(
        out=out,
        episodes=episodes,
        frames=sum(e.length for e in episodes),
        seconds=time.perf_counter() - t0,
        codec=opts.codec,
        formats=opts.formats,
        finish_order=tuple(r.worker for r in results),
        workers=len(jobs),
        discarded=sum(r.discarded for r in results),
    )


def kept_note(workdir: Path, kept: int) -> str:
    return (
        f"nothing was written to --out; the workers' {kept} finished episode(s) are kept in {workdir}/worker-*/ "
        "(one LeRobot v3 dataset each; `openral-data episodes merge` joins them)"
    )


def _assemble(results: list[WorkerResult], workdir: Path, held: Claim, formats: tuple[str, ...]) -> list[EpisodeRecord]:
    """Merge the workers' shares into a staging folder and rename it over `held.out`, whose lock is let go of
    right before the rename (the staged dataset carries no lock file into place)."""
    out = held.out
    # a recorded episode always carries its seed (only an edited one may not know it)
    by_seed = sorted((e for r in results for e in r.episodes), key=lambda e: e.seed or 0)
    episodes = [EpisodeRecord(k, e.length, e.success, e.seed) for k, e in enumerate(by_seed)]
    # a worker that kept no episode (`keep="success"`) left no dataset behind
    folders = [r.worker for r in sorted(results, key=lambda r: r.worker) if r.episodes]
    if not folders:
        dropped = sum(r.discarded for r in results)
        raise ExecutorError(f"{out}: no worker kept an episode ({dropped} discarded)", code="executor.nothing_kept")
    worker_dirs = [worker_dir(workdir, w) for w in folders]

    def add_bags(staging: Path) -> None:
        _keep_settings(worker_dirs[0], staging, len(episodes))
        if "mcap" not in formats:
            return
        dest = staging / MCAP_SUBDIR
        dest.mkdir(parents=True, exist_ok=True)
        for wdir in worker_dirs:
            for bag in finished_bags(wdir / MCAP_SUBDIR):
                if (dest / bag.name).exists():
                    raise ExecutorError(f"{bag}: two workers wrote episode bag {bag.name}")
                os.replace(bag, dest / bag.name)
        names = [b.name for b in finished_bags(dest)]
        if names != [f"episode_{k:06d}" for k in range(len(episodes))]:
            raise ExecutorError(f"{out}: worker bags {names} are not episodes 0..{len(episodes) - 1}")

    if "lerobot" in formats:
        merge_shards(
            [SourceDataset(d) for d in worker_dirs],
            out,
            "record --workers",
            where=workdir,
            order=lambda se: se[0].seed(se[1]),
            before_publish=add_bags,
            before_rename=held.release,
            out_checked=True,
        )
    else:
        staged = Staging(out, "openral-data record --workers")
        with staged as staging:
            add_bags(staging)
            staged.publish(before_rename=held.release)  # refuses an `out` that filled up meanwhile
    return episodes


def _keep_settings(first_worker: Path, staging: Path, total: int) -> None:
    """`record --resume` continues the merged dataset: worker 0's settings (its seed is the first) for all."""
    path = first_worker / layout.RECORD_PATH
    if not path.is_file():
        return
    settings = parse_json(atomic.read_control(path))
    settings["options"]["n_episodes"] = total
    dest = staging / layout.RECORD_PATH
    dest.parent.mkdir(parents=True, exist_ok=True)
    dest.write_text(json.dumps(settings, indent=2))
