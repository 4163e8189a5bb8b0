"""LeRobot v3 (or v2.x read in place) -> one robomimic HDF5 file, the layout robomimic's `SequenceDataset` and
MimicGen read (`formats.hdf5.robomimic_writer`).

An episode is ``data/demo_N`` (N from 0, in episode order): ``actions`` (float32, as the dataset stores them),
``rewards`` (``next.reward``, else 0), ``dones`` (1 on the last step), ``success`` (``next.success``, when the
dataset has it), ``obs/state`` (``observation.state``), ``obs/object`` (``observation.environment_state``, robomimic's
name for the object state), ``obs/<camera>_image`` (decoded frames, uint8 HxWxC) and ``obs/<camera>_depth`` (a
depth or mask camera, uint16 HxWx1); its attributes ``num_samples``, ``episode_index`` (the source's number),
``ep_meta`` (JSON: ``lang``, its language instruction, as RoboCasa and robomimic 0.5 store it) and
``seed``/``success`` when known. ``data.attrs["env_args"]`` names the task
(``env_name``: the episodes' one task, else the dataset's name), ``type`` 1 and ``env_kwargs.control_freq`` (the
frame rate). Each split of the dataset (info.json's `splits`) is a filter key ``mask/<split>`` (``val`` and
``validation`` are written ``valid``, robomimic's name). `--workers N` writes N parts in N processes, copied
into the file in order. The file is written in a hidden staging folder and appears complete or not at all.
"""

from __future__ import annotations

import json
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import h5py

from openral_data.convert.export_source import ExportSource, Written, not_carried, read_export_source
from openral_data.convert.to_mcap import ExportSummary, ProgressFn
from openral_data.errors import OutputExists
from openral_data.formats.atomic import fsync_dir, fsync_file
from openral_data.formats.hdf5.robomimic_writer import DATA, DemoWriter, demo_name, write_header, write_masks
from openral_data.formats.lerobot_v3.images import ENVIRONMENT_STATE
from openral_data.formats.lerobot_v3.masks import is_mask
from openral_data.formats.lerobot_v3.success import episode_successes
from openral_data.formats.lerobot_v3.variants import camera_layout, is_depth
from openral_data.formats.staging import Staging
from openral_data.paths import check_file_output
from openral_data.runtime.parallel.choice import check_workers, contiguous_blocks
from openral_data.types import EpisodeRecord

if TYPE_CHECKING:
    from openral_data.types import Frame

ROBOSUITE_TYPE = 1  # robomimic's EnvType.ROBOSUITE_TYPE, the env type its scripts and MimicGen expect
SPLIT_NAMES = {"val": "valid", "validation": "valid"}  # robomimic calls its validation filter key `valid`


@dataclass(frozen=True)
class DemoJob:
    """Episodes (positions in the dataset's episode rows) written as demos numbered from `first` into `out`."""

    src: Path
    out: Path
    rows: tuple[int, ...]
    first: int


DemoDone = Written[DemoJob]


def demo_keys(source: ExportSource) -> dict[str, tuple[tuple[int, ...], str]]:
    """A demo's datasets: path under ``data/demo_N`` -> (one step's shape, dtype)."""
    features = source.features
    keys: dict[str, tuple[tuple[int, ...], str]] = {
        "actions": (_shape(features, "action"), "float32"),
        "rewards": ((), "float32"),
        "dones": ((), "int64"),
        "obs/state": (_shape(features, "observation.state"), "float32"),
    }
    if "next.success" in features:
        keys["success"] = ((), "int64")
    if ENVIRONMENT_STATE in features:
        keys["obs/object"] = (_shape(features, ENVIRONMENT_STATE), "float32")
    for name, feature in source.cams.items():
        keys[_camera_key(name, feature)] = _camera_shape(feature)
    return keys


def _shape(features: dict[str, Any], key: str) -> tuple[int, ...]:
    return tuple(int(d) for d in features[key].get("shape") or ())


def _camera_key(name: str, feature: dict[str, Any]) -> str:
    return f"obs/{name}_depth" if is_depth(feature) or is_mask(feature) else f"obs/{name}_image"


def _camera_shape(feature: dict[str, Any]) -> tuple[tuple[int, ...], str]:
    height, width, channels = (int(d) for d in camera_layout(feature)["shape"])
    if is_depth(feature) or is_mask(feature):
        return (height, width, 1), "uint16"
    return (height, width, channels), "uint8"


def export_robomimic(
    src: Path, out: Path, *, episodes: str | None = None, workers: int = 1, progress: ProgressFn | None = None
) -> ExportSummary:
    """Write episodes `episodes` (default: all) of the dataset at `src` as the robomimic HDF5 file `out` (new)."""
    check_workers(workers)
    source = read_export_source(src)
    chosen = source.choose(episodes, "export to robomimic")
    _check_new_file(out)
    summary = ExportSummary(src=src, dst=out, skipped_features=not_carried(source), format="robomimic")
    t0 = time.perf_counter()
    staged = Staging(out, "openral-data export")
    with staged as staging:
        whole = staging / out.name
        blocks = contiguous_blocks(len(chosen), workers)
        parts = [staging / f"part-{w:03d}.hdf5" for w in range(len(blocks))] if len(blocks) > 1 else [whole]
        jobs = [DemoJob(src, part, tuple(chosen[i] for i in b), b.start) for part, b in zip(parts, blocks, strict=True)]
        total = sum(int(source.rows[e]["length"]) for e in chosen)
        for result in _run(jobs, progress, total):
            summary.episodes += result.episodes
            summary.frames += result.frames
        with h5py.File(whole, "a") as f:
            _copy_parts(f, parts if len(parts) > 1 else [])
            write_header(f, summary.frames, _env_args(source, chosen))
            write_masks(f, _masks(source, chosen))
        summary.seconds = time.perf_counter() - t0
        _publish(whole, out)
        staged.discard()
    return summary


def _check_new_file(out: Path) -> None:
    check_file_output(out, "OUT")
    if out.exists() or out.is_symlink():
        raise OutputExists(f"{out}: OUT exists; refusing to overwrite it")


def _publish(whole: Path, out: Path) -> None:
    """The finished file under `out`'s name, never over a file that appeared meanwhile (a hard link fails then)."""
    fsync_file(whole)
    try:
        os.link(whole, out)
    except FileExistsError:
        raise OutputExists(f"{out}: OUT appeared while it was being written; not replaced") from None
    fsync_dir(out.parent)


def _run(jobs: list[DemoJob], progress: ProgressFn | None, total: int) -> list[DemoDone]:
    """The jobs here (one) or in worker processes; results in job order."""
    if len(jobs) <= 1:
        return [write_demos(job, progress) for job in jobs]
    from openral_data.convert.worker import init_convert_worker
    from openral_data.runtime.parallel.executors import run_local

    frames = [0]

    def on_finished(result: DemoDone) -> None:
        frames[0] += result.frames
        if progress is not None:
            progress(frames[0], total)

    return sorted(run_local(jobs, write_demos, init_convert_worker, on_finished), key=lambda r: r.job.first)


def _copy_parts(f: h5py.File, parts: list[Path]) -> None:
    """The workers' demos copied into `f` in order."""
    data = f.require_group(DATA)
    for part in parts:
        with h5py.File(part, "r") as p:
            for name in p[DATA]:
                p.copy(p[DATA][name], data, name=name)
        part.unlink()


def write_demos(job: DemoJob, progress: ProgressFn | None = None) -> DemoDone:
    """Write the demos `job` names into its file, one episode each, in order."""
    source = read_export_source(job.src)
    keys = demo_keys(source)
    successes = episode_successes(job.src, source.episodes)
    done = DemoDone(job)
    with h5py.File(job.out, "a") as f:
        data = f.require_group(DATA)
        for k, e in enumerate(job.rows):
            row = source.rows[e]
            number, n = int(row["episode_index"]), int(row["length"])
            demo = DemoWriter(data, demo_name(job.first + k), n, keys)
            task = ""
            for t, frame in enumerate(source.frames(row)):
                demo.put(t, _step(source, frame, t == n - 1))
                task = task or frame.task
                done.frames += 1
                if progress is not None:
                    progress(done.frames, 0)
            seed, success = row.get("openral.seed"), successes.get(number)
            attrs: dict[str, Any] = {"episode_index": number, "ep_meta": json.dumps({"lang": task})}
            attrs |= {"seed": int(seed)} if seed is not None else {}
            attrs |= {"success": bool(success)} if success is not None else {}
            demo.finish(attrs)
            done.episodes.append(EpisodeRecord(number, n, success, None if seed is None else int(seed)))
    done.finished_at = time.monotonic()
    return done


def _step(source: ExportSource, frame: Frame, last: bool) -> dict[str, Any]:
    """One frame as a demo step's values."""
    values: dict[str, Any] = {
        "actions": frame.action,
        "rewards": frame.reward if "next.reward" in source.features else 0.0,
        "dones": int(last),
        "obs/state": frame.state,
    }
    if "next.success" in source.features:
        values["success"] = int(frame.success)
    if frame.environment_state is not None:
        values["obs/object"] = frame.environment_state
    for name, pixels in frame.images.items():
        feature = source.cams[name]
        values[_camera_key(name, feature)] = pixels[..., None] if pixels.ndim == 2 else pixels
    return values


def _env_args(source: ExportSource, chosen: list[int]) -> dict[str, Any]:
    """``env_args``: the episodes' one task as ``env_name`` (else the dataset's name), the frame rate."""
    tasks = {t for e in chosen for t in (source.rows[e].get("tasks") or [])}
    name = next(iter(tasks)) if len(tasks) == 1 else source.path.name
    return {"env_name": name, "type": ROBOSUITE_TYPE, "env_kwargs": {"control_freq": source.fps}}


def _masks(source: ExportSource, chosen: list[int]) -> dict[str, list[str]]:
    """Each split's demo names (demos numbered in `chosen` order)."""
    masks: dict[str, list[str]] = {}
    for k, e in enumerate(chosen):
        split = source.split_of(source.rows[e])
        masks.setdefault(SPLIT_NAMES.get(split, split), []).append(demo_name(k))
    return masks
