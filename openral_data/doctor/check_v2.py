"""`doctor` on a LeRobot v2.0/v2.1 dataset (read in place, `formats.lerobot_v2`): what applies to its layout.

Codes (stable): ``v2.meta`` (info.json, episodes.jsonl or tasks.jsonl unusable: the other checks stop),
``v2.data.missing`` / ``v2.video.missing`` (an episode's parquet or mp4 absent), ``v2.data.rows`` (an episode's
parquet does not hold its ``length`` frames 0..n-1 of that episode), ``v2.data.index`` (a warning: its global
``index`` is not the range the episode order gives, e.g. a subset of a larger dataset), ``v2.data.timestamps``
(a timestamp off ``frame_index / fps``), ``v2.data.task_index`` (a task index with no task), ``v2.video.frames``
(an mp4 with fewer frames than the episode), ``v2.stats`` (v2.1 without a per-episode stats line per episode,
v2.0 without meta/stats.json: a warning) and, with ``--deep``, ``v2.video.content`` (decoded frames whose
per-channel mean is not the episode's stored image mean). `--repair` is refused: `openral-data upgrade` writes
a v3 dataset, which doctor can repair.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import av
import numpy as np
import pyarrow as pa

from openral_data.doctor.check_deep import TOLERANCE, decoded_means
from openral_data.doctor.check_scan import check_scan
from openral_data.doctor.check_video import Placement
from openral_data.doctor.findings import SCAN_VIDEO_LENGTH, Finding, error, warning
from openral_data.doctor.inspect import DAMAGE
from openral_data.errors import DatasetError
from openral_data.formats import lerobot_v2
from openral_data.formats.dataset import LeRobotDataset, open_lerobot
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.reader import video_keys
from openral_data.formats.lerobot_v3.video import count_packets
from openral_data.formats.parquetfile import read_table
from openral_data.metrics.signals import video_disagreement

TIME_TOLERANCE = 1e-4  # s: float32 of t / fps


def legacy_version(root: Path) -> str | None:
    """The v2.x version `root`'s info.json says, when its meta/episodes.jsonl is there too (a v3 layout labelled
    v2.x is the v3 checks' ``info.version`` error); None otherwise (also when info.json is unreadable: the v3
    checks report that)."""
    try:
        version = lerobot_v2.version(lerobot_v2.read_raw_info(root))
    except (DatasetError, OSError):
        return None
    v3_layout = not os.path.lexists(root / lerobot_v2.EPISODES_PATH) and os.path.lexists(root / "meta/episodes")
    return None if v3_layout else version


def check_v2(root: Path, *, deep: bool = False) -> list[Finding]:
    """Every finding for the v2.x dataset at `root`; never raises on a damaged one (a check that cannot read
    what it needs is a ``check.failed`` error, as in the v3 checks)."""
    try:
        ds = open_lerobot(root)
        episodes = ds.committed_episodes()
        tasks = ds.tasks()
    except DatasetError as exc:
        return [error("v2.meta", "dataset", str(exc).removeprefix(f"{root}/"))]
    rows = episodes.to_pylist()
    out: list[Finding] = []
    try:
        out += _check_data(ds, rows, len(tasks))
        out += _check_videos(ds, rows, deep)
        out += check_scan(ds.root, ds.info, ds.data_files())
    except DAMAGE as exc:
        out.append(error("check.failed", "dataset", f"a check cannot read the dataset: {exc!r}"))
    return out + _check_stats(ds, rows)


def _rel(ds: LeRobotDataset, path: Path) -> str:
    return str(path.relative_to(ds.root)) if path.is_relative_to(ds.root) else str(path)


def _check_data(ds: LeRobotDataset, rows: list[dict[str, Any]], n_tasks: int) -> list[Finding]:
    out: list[Finding] = []
    fps = int(ds.info["fps"])
    for row, path in zip(rows, lerobot_v2.data_files(ds.root, ds.info, pa.Table.from_pylist(rows)), strict=True):
        e, n, start = int(row["episode_index"]), int(row["length"]), int(row["dataset_from_index"])
        if not path.is_file():
            out.append(error("v2.data.missing", _rel(ds, path), f"missing (data of episode {e})"))
            continue
        try:
            cols = read_table(path, columns=["episode_index", "frame_index", "index", "timestamp", "task_index"])
        except DatasetError as exc:
            out.append(error("v2.data.rows", _rel(ds, path), str(exc).split(": ", 1)[-1]))
            continue
        got = {k: cols.column(k).to_pylist() for k in cols.column_names}
        want = {"episode_index": [e] * n, "frame_index": list(range(n))}
        bad = [k for k, v in want.items() if got.get(k) != v]
        if bad:
            out.append(
                error("v2.data.rows", _rel(ds, path), f"{', '.join(bad)}: not the {n} frames of episode {e} in order")
            )
            continue
        if got.get("index") != list(range(start, start + n)):  # e.g. a subset of a larger dataset's episodes
            message = f"index: not {start}..{start + n - 1}, the frames' place in episode order (`upgrade` renumbers)"
            out.append(warning("v2.data.index", _rel(ds, path), message))
        times = np.asarray(got.get("timestamp", []), dtype=np.float64)
        if len(times) != n or np.abs(times - np.arange(n) / fps).max(initial=0) > TIME_TOLERANCE:
            out.append(error("v2.data.timestamps", _rel(ds, path), f"timestamps are not frame_index / {fps}"))
        task_ids = got.get("task_index", [])
        if any(not isinstance(t, int) or not 0 <= t < n_tasks for t in task_ids):
            out.append(error("v2.data.task_index", _rel(ds, path), f"a task_index outside 0..{n_tasks - 1}"))
    return out


def _video_path(ds: LeRobotDataset, row: dict[str, Any], key: str) -> Path:
    pos = layout.FilePos(row[f"videos/{key}/chunk_index"], row[f"videos/{key}/file_index"])
    return layout.template_path(ds.root, ds.info, "video_path", pos, video_key=key)


def _check_videos(ds: LeRobotDataset, rows: list[dict[str, Any]], deep: bool) -> list[Finding]:
    out: list[Finding] = []
    means = _stored_means(ds) if deep else {}
    for key in video_keys(ds.info):
        for row in rows:
            e, n, path = int(row["episode_index"]), int(row["length"]), _video_path(ds, row, key)
            if not path.is_file():
                out.append(error("v2.video.missing", _rel(ds, path), f"missing (video of episode {e})"))
                continue
            try:
                frames = len(count_packets(path))
            except (av.error.FFmpegError, OSError, IndexError):
                frames = 0
            if frames < n:
                out.append(error("v2.video.frames", _rel(ds, path), f"{frames} frame(s), episode {e} has {n}"))
                continue
            longer = video_disagreement(n, frames, None, float(ds.info["fps"]))
            if longer:  # lerobot loads it (its frames are looked up by timestamp), but the rows end early
                out.append(warning(SCAN_VIDEO_LENGTH, _rel(ds, path), f"episode {e}: {longer}"))
            want = means.get((e, key))
            if deep and want is not None:
                got = decoded_means(path, [Placement(e, n, 0.0, n / int(ds.info["fps"]))], int(ds.info["fps"]))
                if e not in got or np.abs(got[e] - want).max() > TOLERANCE:
                    message = f"decoded frames do not match episode {e}'s stored image mean (off by > {TOLERANCE:g})"
                    out.append(error("v2.video.content", _rel(ds, path), message))
    return out


def _stored_means(ds: LeRobotDataset) -> dict[tuple[int, str], np.ndarray[Any, Any]]:
    """(episode, camera) -> the per-channel mean meta/episodes_stats.jsonl stores (v2.1; v2.0 has none)."""
    out: dict[tuple[int, str], np.ndarray[Any, Any]] = {}
    try:
        lines = lerobot_v2.read_jsonl(layout.inside(ds.root, lerobot_v2.EPISODES_STATS_PATH))
    except (FileNotFoundError, DatasetError):
        return out  # v2.stats reports it
    for line in lines:
        stats = line.get("stats")
        for key in video_keys(ds.info):
            feature = stats.get(key) if isinstance(stats, dict) else None
            mean = feature.get("mean") if isinstance(feature, dict) else None
            if isinstance(line.get("episode_index"), int) and mean is not None:
                try:
                    out[(line["episode_index"], key)] = np.asarray(mean, dtype=np.float64).ravel()
                except (TypeError, ValueError):
                    continue  # not numbers: no mean to compare with
    return out


def _check_stats(ds: LeRobotDataset, rows: list[dict[str, Any]]) -> list[Finding]:
    if ds.legacy == "v2.0":
        if (ds.root / lerobot_v2.STATS_PATH).is_file():
            return []
        return [warning("v2.stats", lerobot_v2.STATS_PATH, "missing: `upgrade` computes the stats from the frames")]
    where = lerobot_v2.EPISODES_STATS_PATH
    try:
        lines = lerobot_v2.read_jsonl(layout.inside(ds.root, where))
    except FileNotFoundError:
        return [warning("v2.stats", where, "missing: `upgrade` computes the per-episode stats from the frames")]
    except DatasetError as exc:
        return [warning("v2.stats", where, str(exc).split(": ", 1)[-1])]
    have = {line.get("episode_index") for line in lines if isinstance(line.get("stats"), dict)}
    lacking = [int(r["episode_index"]) for r in rows if r["episode_index"] not in have]
    if lacking:
        return [warning("v2.stats", where, f"no stats line for episode(s) {lacking[:5]}")]
    return []
