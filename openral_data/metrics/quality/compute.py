"""Quality of every episode of one dataset, streamed: data files one at a time (two passes: each dimension's
observed range, then the measures episode by episode), each camera decoded episode by episode with PyAV.

Memory is bounded by one data file's episode_index/frame_index/timestamp/state/action columns and one decoded
frame per camera, whatever the dataset's size.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pyarrow as pa
import pyarrow.compute as pc

from openral_data.errors import DatasetError
from openral_data.formats.lerobot_v3.features import ACTION, STATE
from openral_data.formats.lerobot_v3.frames import decode_episode_video, depth_settings
from openral_data.formats.lerobot_v3.reader import read_episodes
from openral_data.formats.parquetfile import read_table
from openral_data.metrics.quality import dims, motion, timing
from openral_data.metrics.quality.camera import camera_quality
from openral_data.metrics.quality.table import CAMERA_MEASURES, finish
from openral_data.metrics.quality.thresholds import Thresholds
from openral_data.metrics.sources import DatasetSource

Array = npt.NDArray[np.float64]
Ranges = dict[str, tuple[Array, Array]]
Progress = Callable[[int], None]


def vectors(table: pa.Table, key: str, path: Path) -> Array:
    """A list column as a float64 (rows, dims) array; NaN/Inf kept (the measures skip them)."""
    col = table.column(key).combine_chunks()
    n = len(col)
    flat = pc.list_flatten(col).to_numpy(zero_copy_only=False).astype(np.float64)
    if n and len(flat) % n:
        raise DatasetError(f"{path}: {key}: rows of different lengths", code="dataset.invalid")
    return np.asarray(flat.reshape(n, len(flat) // n if n else 0), dtype=np.float64)


def observed_ranges(ds: DatasetSource) -> Ranges:
    """Each vector's per-dimension finite min and max over the whole dataset (one data file read at a time)."""
    keys = [k for k in (STATE, ACTION) if k in ds.data_columns]
    out: Ranges = {}
    for path in ds.data_files:
        table = read_table(path, columns=keys)
        for key in keys:
            x = vectors(table, key, path)
            if not len(x):
                continue
            finite = np.where(np.isfinite(x), x, np.nan)
            lo, hi = np.nanmin(finite, axis=0), np.nanmax(finite, axis=0)
            if key in out:
                lo, hi = np.fmin(out[key][0], lo), np.fmax(out[key][1], hi)
            out[key] = (lo, hi)
    return {k: (np.nan_to_num(lo), np.nan_to_num(hi)) for k, (lo, hi) in out.items()}


def episode_motion(
    ds: DatasetSource, arrays: dict[str, Array], timestamps: Array, ranges: Ranges, th: Thresholds
) -> dict[str, Any]:
    """The state/action/timestamp measures of one episode (`arrays`: its state and action, frames in order)."""
    n, fps = len(timestamps), ds.fps
    z = {k: motion.normalised(x, *ranges[k]) for k, x in arrays.items() if k in ranges}
    speed = {k: motion.speeds(v, fps) for k, v in z.items()}
    idle = motion.idle_frames(speed.get(STATE), speed.get(ACTION), n, th.idle_speed)
    head, tail = motion.run_lengths(idle)
    frozen: list[dims.Frozen] = []
    clip: dict[str, float | None] = {}
    grippers: list[tuple[Array, float, float]] = []
    arm: dict[str, Array] = {}  # the trajectory without gripper dimensions (open/close steps are no jerk)
    for key, x in arrays.items():
        if key not in ranges:
            continue
        lo, hi = ranges[key]
        names = ds.dim_names(key)
        grip = dims.gripper_dims(names)
        varies = (hi > lo) & ~np.isin(np.arange(len(names)), grip)  # a gripper holds still on purpose
        frozen += dims.frozen_dims(key, x, names, varies, th.frozen_min_frames, th.frozen_min_share)
        clip[key] = dims.clip_fraction(x, lo, hi, set(grip), th.clip_plateau)
        arm[key] = motion.normalised(x[:, varies], lo[varies], hi[varies])
        if key == ACTION or not dims.gripper_dims(ds.dim_names(ACTION)):
            grippers += [(x[:, g], float(lo[g]), float(hi[g])) for g in grip]
    toggles = max((dims.toggles(*g) for g in grippers), default=None)
    steps = timing.timestamp_steps(timestamps, fps)
    trajectory = arm.get(ACTION, arm.get(STATE))
    return {
        "idle_fraction": float(idle.mean()) if n else 0.0,
        "idle_head": head,
        "idle_tail": tail,
        "frozen_dims": [f.__dict__ for f in frozen],
        "ldlj": motion.windowed_ldlj(trajectory, fps, th.jerk_window_s) if trajectory is not None else None,
        "gripper_toggles": toggles,
        "gripper_toggles_per_s": None if toggles is None or not n else toggles * fps / n,
        "action_clip_fraction": clip.get(ACTION),
        "state_clip_fraction": clip.get(STATE),
        "timestamp_jitter": timing.jitter(steps, th.gap_frames),
        "timestamp_gaps": timing.gaps(steps, th.gap_frames),
    }


def file_episodes(ds: DatasetSource, path: Path, ranges: Ranges, th: Thresholds) -> dict[int, dict[str, Any]]:
    """The motion measures of every episode in data file `path`."""
    keys = [k for k in (STATE, ACTION) if k in ds.data_columns]
    table = read_table(path, columns=["episode_index", "frame_index", "timestamp", *keys])
    try:
        table = table.sort_by([("episode_index", "ascending"), ("frame_index", "ascending")])
    except (KeyError, pa.ArrowException) as exc:
        raise DatasetError(f"{path}: episode_index/frame_index: {exc}", code="dataset.invalid") from None
    episodes = table.column("episode_index").to_numpy(zero_copy_only=False)
    stamps = table.column("timestamp").to_numpy(zero_copy_only=False).astype(np.float64)
    arrays = {k: vectors(table, k, path) for k in keys}
    out: dict[int, dict[str, Any]] = {}
    bounds = np.flatnonzero(np.diff(episodes)) + 1
    for a, b in zip(np.concatenate([[0], bounds]), np.concatenate([bounds, [len(episodes)]]), strict=True):
        if b > a:
            part = {k: x[a:b] for k, x in arrays.items()}
            out[int(episodes[a])] = episode_motion(ds, part, stamps[a:b], ranges, th)
    return out


def rgb_cameras(ds: DatasetSource) -> list[str]:
    """The video features holding colour pictures (a depth map's luma means nothing)."""
    return [k for k in ds.cameras if depth_settings(ds.info, k) is None]


def episode_cameras(ds: DatasetSource, row: dict[str, Any], stride: int, th: Thresholds) -> dict[str, Any]:
    """The camera measures of episode `row` (meta/episodes), the worst camera's share of each, and which
    cameras raise which flag."""
    worst = dict.fromkeys(CAMERA_MEASURES, 0.0)
    raised: list[str] = []
    first_black: int | None = None
    for key in rgb_cameras(ds):
        q = camera_quality(decode_episode_video(ds.root, ds.info, row, key), stride, th)
        for measure in CAMERA_MEASURES:
            share = getattr(q, measure)
            worst[measure] = max(worst[measure], share)
            if share >= th.camera_flag:
                raised.append(f"{key}:{measure}")
        if q.first_black is not None:
            first_black = q.first_black if first_black is None else min(first_black, q.first_black)
    return {
        **{f"camera_{m}_fraction": v for m, v in worst.items()},
        "camera_first_black": first_black,
        "camera_flags": raised,
    }


def dataset_quality(ds: DatasetSource, stride: int, th: Thresholds, progress: Progress | None = None) -> pa.Table:
    """One row per episode of `ds` (table.SCHEMA), in episode order."""
    ranges = observed_ranges(ds)
    rows: dict[int, dict[str, Any]] = {}
    for path in ds.data_files:
        rows.update(file_episodes(ds, path, ranges, th))
    cameras = bool(rgb_cameras(ds))
    for row in read_episodes(ds.root).to_pylist():
        e = int(row["episode_index"])
        if e not in rows:
            raise DatasetError(f"{ds.root}: episode {e}: no frames in data/", code="dataset.invalid")
        if cameras and int(row["length"]):
            rows[e].update(episode_cameras(ds, row, stride, th))
        if progress is not None:
            progress(1)
    return finish(rows, th, stride, has_cameras=cameras)
