"""LeRobot v3 (or v2.x read in place) -> an RLDS / TFDS build folder: the Open X-Embodiment layout that
`tfds.builder_from_directory(OUT)` loads with no code of ours, written without TensorFlow (`formats.rlds.writer`).

An episode is one Example: per step ``observation/<camera>`` (an RGB camera's decoded frame re-encoded as a JPEG
or PNG image; a depth or mask camera a uint16 HxW tensor), ``observation/state``, ``observation/environment_state``
(when the dataset has one), ``action``, ``reward`` (``next.reward``, else 0), ``discount`` (1), ``is_first``,
``is_last``, ``is_terminal`` (the frame's ``next.success``: a success ends the task) and ``language_instruction``
(the frame's task); per episode ``episode_metadata/episode_index`` (the source's number), ``seed`` (-1 when
unknown) and ``success`` (-1 unknown, 0, 1). Each split of the dataset (info.json's `splits`) is a TFDS split of
its own; `--workers N` writes each split's episodes as N shards in N processes, one shard a worker. The folder is
staged and appears complete or not at all.
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from openral_data.convert.export_source import ExportSource, Written, not_carried, read_export_source
from openral_data.convert.to_mcap import ExportSummary, ProgressFn
from openral_data.errors import DatasetError, UsageError
from openral_data.formats.lerobot_v3.images import ENVIRONMENT_STATE
from openral_data.formats.lerobot_v3.masks import is_mask
from openral_data.formats.lerobot_v3.success import episode_successes
from openral_data.formats.lerobot_v3.variants import camera_layout, is_depth
from openral_data.formats.rlds.writer import (
    Column,
    EpisodeExample,
    ShardWriter,
    SplitShards,
    dataset_info_doc,
    features_doc,
    shard_name,
    write_json,
)
from openral_data.formats.staging import Staging, check_new_output
from openral_data.runtime.parallel.choice import check_workers, contiguous_blocks
from openral_data.types import EpisodeRecord

if TYPE_CHECKING:
    from openral_data.types import Frame

IMAGE_FORMATS = ("jpeg", "png")
OBSERVATION = "steps/observation/"


@dataclass(frozen=True)
class ShardJob:
    """One shard: the episodes (positions in the dataset's episode rows) of one split a worker writes."""

    src: Path
    folder: Path
    name: str
    split: str
    shard: int
    shards: int
    rows: tuple[int, ...]
    image_format: str


ShardDone = Written[ShardJob]


def dataset_name(dst: Path) -> str:
    """The TFDS name of the folder `dst` (its shards' prefix): its name in snake case, `dataset` if none is left."""
    name = re.sub(r"[^a-z0-9]+", "_", dst.name.lower()).strip("_")
    return name if name and name[0].isalpha() else f"dataset_{name}".rstrip("_")


def rlds_columns(source: ExportSource, image_format: str) -> list[Column]:
    """What an episode of the dataset is written as (see the module docstring)."""
    features = source.features
    cols = [Column(f"{OBSERVATION}{name}", *_camera(f, image_format)) for name, f in source.cams.items()]
    cols.append(Column(f"{OBSERVATION}state", "tensor", "float32", _width(features, "observation.state")))
    if ENVIRONMENT_STATE in features:
        cols.append(Column(f"{OBSERVATION}environment_state", "tensor", "float32", _width(features, ENVIRONMENT_STATE)))
    cols.append(Column("steps/action", "tensor", "float32", _width(features, "action")))
    cols += [Column("steps/reward", "tensor"), Column("steps/discount", "tensor")]
    cols += [Column(f"steps/{k}", "tensor", "bool") for k in ("is_first", "is_last", "is_terminal")]
    cols.append(Column("steps/language_instruction", "text"))
    return cols + [Column(f"episode_metadata/{k}", "tensor", "int64") for k in ("episode_index", "seed", "success")]


def _camera(feature: dict[str, Any], image_format: str) -> tuple[Any, ...]:
    """A camera's column: kind, dtype, shape, image format."""
    height, width, channels = (int(d) for d in camera_layout(feature)["shape"])
    if is_depth(feature) or is_mask(feature):
        return ("tensor", "uint16", (height, width))
    return ("image", "uint8", (height, width, channels), image_format)


def _width(features: dict[str, Any], key: str) -> tuple[int, ...]:
    shape = features[key].get("shape")
    if not isinstance(shape, list | tuple) or len(shape) != 1 or not str(shape[0]).isdigit():
        raise DatasetError(f"{key}: shape {shape!r} is not one dimension", code="dataset.invalid")
    return (int(shape[0]),)


def export_rlds(
    src: Path,
    dst: Path,
    *,
    episodes: str | None = None,
    workers: int = 1,
    image_format: str = "jpeg",
    progress: ProgressFn | None = None,
) -> ExportSummary:
    """Write episodes `episodes` (default: all) of the dataset at `src` as the RLDS build folder `dst` (new):
    each split's episodes in `workers` shards, then features.json and dataset_info.json; DST published last."""
    check_workers(workers)
    if image_format not in IMAGE_FORMATS:
        raise UsageError(f"--image-format: {image_format!r} is not one of {', '.join(IMAGE_FORMATS)} (RLDS)")
    source = read_export_source(src)
    chosen = source.choose(episodes, "export to RLDS")
    check_new_output(dst, "OUT")
    name = dataset_name(dst)
    columns = rlds_columns(source, image_format)
    summary = ExportSummary(src=src, dst=dst, skipped_features=not_carried(source), format="rlds")
    t0 = time.perf_counter()
    staged = Staging(dst, "openral-data export")
    with staged as staging:
        jobs = _jobs(source, chosen, staging, name, workers, image_format)
        done = _run(jobs, workers, progress, sum(int(source.rows[e]["length"]) for e in chosen))
        splits: dict[str, SplitShards] = {}
        for result in done:
            split = splits.setdefault(result.job.split, SplitShards(result.job.split, [], 0))
            split.shard_lengths.append(len(result.episodes))
            split.num_bytes += result.bytes
            summary.episodes += result.episodes
            summary.frames += result.frames
        write_json(staging / "features.json", features_doc(columns))
        write_json(staging / "dataset_info.json", dataset_info_doc(name, list(splits.values()), _description(src)))
        summary.seconds = time.perf_counter() - t0
        staged.publish("OUT")
    return summary


def _description(src: Path) -> str:
    return f"Exported by openral-data from the LeRobot dataset {src.name}"


def _jobs(
    source: ExportSource, chosen: list[int], folder: Path, name: str, workers: int, image_format: str
) -> list[ShardJob]:
    """Each split's chosen episodes (splits in the order their first episode comes) in near-equal shards."""
    by_split: dict[str, list[int]] = {}
    for e in chosen:
        by_split.setdefault(source.split_of(source.rows[e]), []).append(e)
    jobs = []
    for split, rows in by_split.items():
        blocks = contiguous_blocks(len(rows), workers)
        for shard, block in enumerate(blocks):
            picked = tuple(rows[i] for i in block)
            jobs.append(ShardJob(source.path, folder, name, split, shard, len(blocks), picked, image_format))
    return jobs


def _run(jobs: list[ShardJob], workers: int, progress: ProgressFn | None, total: int) -> list[ShardDone]:
    """The shards, here (one worker) or in at most `workers` processes (worker k writes shard k of every split);
    results in job order."""
    if workers == 1 or len(jobs) <= 1:
        done: list[ShardDone] = []
        for job in jobs:
            done.append(write_shard(job, _offset(progress, sum(d.frames for d in done), total)))
        return done
    from openral_data.convert.worker import init_convert_worker
    from openral_data.runtime.parallel.executors import run_local

    finished: list[int] = [0]

    def on_finished(result: WorkerDone) -> None:
        finished[0] += sum(d.frames for d in result.shards)
        if progress is not None:
            progress(finished[0], total)

    shares = [tuple(j for j in jobs if j.shard == k) for k in range(max(j.shard for j in jobs) + 1)]
    results = [d for r in run_local(shares, write_shards, init_convert_worker, on_finished) for d in r.shards]
    return sorted(results, key=lambda r: jobs.index(r.job))


@dataclass
class WorkerDone:
    shards: list[ShardDone]
    finished_at: float


def write_shards(jobs: tuple[ShardJob, ...]) -> WorkerDone:
    """A worker's shards, one after another."""
    done = [write_shard(job) for job in jobs]
    return WorkerDone(done, time.monotonic())


def _offset(progress: ProgressFn | None, before: int, total: int) -> ProgressFn | None:
    """A shard's progress (its frames) as the export's (`before` frames already written)."""
    return None if progress is None else (lambda n, _t: progress(before + n, total))


def write_shard(job: ShardJob, progress: ProgressFn | None = None) -> ShardDone:
    """Write the shard `job` names: its episodes, one Example each, in order."""
    source = read_export_source(job.src)
    columns = rlds_columns(source, job.image_format)
    successes = episode_successes(job.src, source.episodes)
    has_success = "next.success" in source.features
    done = ShardDone(job)
    writer = ShardWriter(job.folder / shard_name(job.name, job.split, job.shard, job.shards))
    try:
        for e in job.rows:
            row = source.rows[e]
            number = int(row["episode_index"])
            example = EpisodeExample(columns)
            n = int(row["length"])
            for t, frame in enumerate(source.frames(row)):
                _add_step(example, source, frame, t, n, has_success)
                done.frames += 1
                if progress is not None:
                    progress(done.frames, 0)
            seed = row.get("openral.seed")
            success = successes.get(number)
            example.add("episode_metadata/episode_index", number)
            example.add("episode_metadata/seed", -1 if seed is None else int(seed))
            example.add("episode_metadata/success", -1 if success is None else int(success))
            writer.write(example.to_bytes())
            done.episodes.append(EpisodeRecord(number, n, success, None if seed is None else int(seed)))
    finally:
        writer.close()
    done.bytes = writer.bytes
    done.finished_at = time.monotonic()
    return done


def _add_step(example: EpisodeExample, source: ExportSource, frame: Frame, t: int, n: int, success: bool) -> None:
    """One frame's values as the step's."""
    for name, pixels in frame.images.items():
        example.add(f"{OBSERVATION}{name}", pixels)
    example.add(f"{OBSERVATION}state", frame.state)
    if frame.environment_state is not None:
        example.add(f"{OBSERVATION}environment_state", frame.environment_state)
    example.add("steps/action", frame.action)
    example.add("steps/reward", frame.reward if "next.reward" in source.features else 0.0)
    example.add("steps/discount", 1.0)
    example.add("steps/is_first", t == 0)
    example.add("steps/is_last", t == n - 1)
    example.add("steps/is_terminal", success and frame.success)
    example.add("steps/language_instruction", frame.task)
