"""Quality of every episode of one dataset, streamed: data files one at a time, each a row group at a time (two
passes: each dimension's observed range, then the measures episode by episode, `stream.episodes`), each camera
decoded episode by episode with PyAV.

Memory is bounded by one row group and one episode of the episode_index/frame_index/timestamp/state/action
columns (a data file out of (episode_index, frame_index) order, a foreign one, is read whole and sorted: then by
that file), the image columns of `dtype: image` cameras (`pictures`) and a few decoded frames per camera
(`camera.chunks`), whatever the dataset's size: per-frame rows go to `Sink`s as they are made (`FrameRows`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from openral_data.errors import DatasetError, VideoEnds
from openral_data.formats.lerobot_v3.features import ACTION, STATE
from openral_data.formats.lerobot_v3.frames import (
    OpenVideos,
    decode_episode_frames,
    decode_episode_video,
    depth_settings,
)
from openral_data.formats.lerobot_v3.reader import read_episodes
from openral_data.formats.parquetfile import read_row_groups
from openral_data.metrics.quality import breadth, cuts, onset, stream, views
from openral_data.metrics.quality.camera import MEASURES as CAMERA_MEASURES
from openral_data.metrics.quality.camera import CameraQuality, camera_quality, luma, short_video, stalled
from openral_data.metrics.quality.edges import Full
from openral_data.metrics.quality.episode import FINDINGS, MOVING, STEPS, PerFrame, Ranges, episode_motion
from openral_data.metrics.quality.findings import Finding
from openral_data.metrics.quality.pictures import ImageColumns, picture_cameras
from openral_data.metrics.quality.stream import vectors
from openral_data.metrics.quality.table import FRAME_SCHEMA, SAMPLE_SCHEMA
from openral_data.metrics.quality.thresholds import Thresholds
from openral_data.metrics.sources import DatasetSource

Progress = Callable[[int], None]
Sink = Callable[[pa.Table], None]
Rows = dict[int, dict[str, Any]]


def observed_ranges(ds: DatasetSource) -> Ranges:
    """Each vector's per-dimension finite min and max over the whole dataset (one row group read at a time)."""
    keys = [k for k in (STATE, ACTION) if k in ds.data_columns]
    out: Ranges = {}
    for path in ds.data_files:
        for table in read_row_groups(path, keys):
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


class FrameRows:
    """Per-frame rows (FRAME_SCHEMA) on their way to a `Sink`, written `FLUSH` rows or more at a time (one
    `write_table` per episode would make a row group per episode)."""

    FLUSH = 1 << 16

    def __init__(self, sink: Sink) -> None:
        self.sink = sink
        self.parts: list[list[Any]] = []
        self.count = 0

    def add(self, episode: int, frame_index: Any, per_frame: PerFrame) -> None:
        n = len(frame_index)
        speeds = [np.full(n, np.nan) if s is None else s for s in (per_frame.state_speed, per_frame.action_speed)]
        self.parts.append([np.full(n, episode, dtype=np.int64), frame_index, *speeds, per_frame.idle])
        self.count += n
        if self.count >= self.FLUSH:
            self.flush()

    def flush(self) -> None:
        """Write the rows held (none: an empty table, as a data file without rows gave); a NaN speed is null."""
        columns = [np.concatenate(c) if c else [] for c in zip(*self.parts, strict=True)] or [[]] * 5
        arrays = [pa.array(c, type=f.type, from_pandas=True) for c, f in zip(columns, FRAME_SCHEMA, strict=True)]
        self.sink(pa.Table.from_arrays(arrays, schema=FRAME_SCHEMA))
        self.parts, self.count = [], 0


def file_episodes(ds: DatasetSource, path: Path, ranges: Ranges, th: Thresholds, frames: Sink) -> Rows:
    """The motion measures of every episode in data file `path`, read an episode at a time (`stream`); its
    per-frame rows go to `frames`."""
    keys = [k for k in (STATE, ACTION) if k in ds.data_columns]
    out: Rows = {}
    rows = FrameRows(frames)
    for episode in stream.episodes(path, keys):
        out[episode.index], per_frame = episode_motion(ds, episode.arrays, episode.stamps, ranges, th)
        rows.add(episode.index, episode.frame_index, per_frame)
    if rows.count or not out:
        rows.flush()
    return out


def motion_pass(ds: DatasetSource, th: Thresholds, frames: Sink) -> Rows:
    ranges = observed_ranges(ds)
    rows: Rows = {}
    for path in ds.data_files:
        rows.update(file_episodes(ds, path, ranges, th, frames))
    return rows


def rgb_cameras(ds: DatasetSource) -> list[str]:
    """The cameras holding colour pictures: video features (a depth map's luma means nothing) and `dtype: image`
    features (a segmentation mask's ids are not pictures)."""
    return [k for k in ds.cameras if depth_settings(ds.info, k) is None] + picture_cameras(ds.info)


@dataclass(frozen=True)
class Pictures:
    """Where a pass reads the cameras' frames: `dtype: image` columns (`images`) or videos, their mp4s kept open
    from one episode to the next (`videos`)."""

    ds: DatasetSource
    images: ImageColumns
    videos: OpenVideos

    def frames(self, row: dict[str, Any], key: str, every: int) -> Iterator[Any]:
        """Frames 0, every, 2*every, ... of camera `key` in episode `row`, as RGB."""
        if key in self.images.keys:
            return self.images.frames(row, key, every)
        return decode_episode_video(self.ds.root, self.ds.info, row, key, every, self.videos)

    def all(self, row: dict[str, Any], key: str) -> Iterator[Any]:
        """Every frame of camera `key` in episode `row`, up to where its video ends."""
        return iter(UntilEnd(self.frames(row, key, 1)))

    def picked(self, row: dict[str, Any], key: str, wanted: Sequence[int]) -> Iterator[Any]:
        """Frames `wanted` (ascending) of camera `key` in episode `row`, as RGB, up to where its video ends; only
        those decoded (`frames.decode_episode_frames`)."""
        if key in self.images.keys:
            return self.images.picked(row, key, wanted)
        return iter(UntilEnd(decode_episode_frames(self.ds.root, self.ds.info, row, key, wanted, self.videos)))


class UntilEnd:
    """A camera's frames up to where its video ends (`VideoEnds`: fewer frames than the episode's rows, a
    finding, not an error); `ends` is then how many frames it holds."""

    def __init__(self, frames: Iterator[Any]) -> None:
        self.frames = frames
        self.ends: int | None = None

    def __iter__(self) -> Iterator[Any]:
        try:
            yield from self.frames
        except VideoEnds as exc:
            self.ends = exc.count


def episode_cameras(
    ds: DatasetSource,
    row: dict[str, Any],
    stride: int,
    th: Thresholds,
    sinks: tuple[Sink, Pictures],
    motion: tuple[Any, Any],
) -> tuple[dict[str, Any], list[Finding], dict[str, CameraQuality]]:
    """The camera measures of episode `row` (meta/episodes): the worst camera's share of each fault, the first
    black frame, and which cameras raise which flag, the cameras' findings and measures; the measured frames go
    to `sinks`' first; `motion`: the frames where the robot moves and the state's step ratios
    (`rows.step_ratios`), each None when unknown."""
    moving, steps = motion
    samples, pictures = sinks
    worst = dict.fromkeys(CAMERA_MEASURES, 0.0)
    raised: list[str] = []
    firsts: list[int] = []
    found: list[Finding] = []
    seen: dict[str, CameraQuality] = {}
    fulls: dict[str, Full] = {}
    length = int(row["length"])
    for key in rgb_cameras(ds):
        frames = UntilEnd(pictures.frames(row, key, stride))
        q = camera_quality(frames, stride, th)
        held = length if frames.ends is None else frames.ends
        fulls[key] = Full(partial(pictures.all, row, key), luma, partial(pictures.picked, row, key))
        found += q.findings(key, th, stride, held, moving, fulls[key])
        if frames.ends is not None:
            found.append(short_video(key, frames.ends, length))
        seen[key] = q
        for measure in CAMERA_MEASURES:
            worst[measure] = max(worst[measure], q.share(measure))
            if q.share(measure) >= th.camera_flag:
                raised.append(f"{key}:{measure}")
        if (first := q.first("black")) is not None:
            firsts.append(first)
        records = [{"episode_index": int(row["episode_index"]), "camera": key, **vars(s)} for s in q.samples]
        samples(pa.Table.from_pylist(records, schema=SAMPLE_SCHEMA))
    found += stalled(seen, th, stride, length, fulls)
    found += onset.camera_lags(fulls, moving, length)
    if steps is not None:
        found += cuts.picture_drops({key: full.change_at for key, full in fulls.items()}, steps)
    measures = {
        **{f"camera_{m}_fraction": v for m, v in worst.items()},
        "camera_first_black": min(firsts, default=None),
        "camera_flags": raised,
    }
    return measures, found, seen


def camera_pass(
    ds: DatasetSource, rows: Rows, stride: int, th: Thresholds, samples: Sink, progress: Progress | None
) -> bool:
    """Add the camera measures to `rows` (every episode meta/episodes lists must have frames); whether the
    dataset has colour cameras."""
    cameras = bool(rgb_cameras(ds))
    thumbs: dict[str, dict[int, Any]] = {}  # camera -> episode -> its mean picture (`views.flipped`)
    lengths: dict[int, int] = {}
    with OpenVideos() as videos:
        pictures = Pictures(ds, ImageColumns(ds.root, picture_cameras(ds.info)), videos)
        for row in read_episodes(ds.root).to_pylist():
            e = int(row["episode_index"])
            if e not in rows:
                raise DatasetError(f"{ds.root}: episode {e}: no frames in data/", code="dataset.invalid")
            rows[e][FINDINGS] += breadth.task_text([t for t in row.get("tasks") or [] if isinstance(t, str)])
            motion = rows[e].pop(MOVING, None), rows[e].pop(STEPS, None)
            if cameras and int(row["length"]):
                measures, found, seen = episode_cameras(ds, row, stride, th, (samples, pictures), motion)
                rows[e].update(measures)
                rows[e][FINDINGS] = cuts.explained(rows[e][FINDINGS], found) + found
                lengths[e] = int(row["length"])
                for key, q in seen.items():
                    if q.thumb is not None:
                        thumbs.setdefault(key, {})[e] = q.thumb
            if progress is not None:
                progress(1)
    for key, mine in thumbs.items():
        for e, found in views.flipped(mine, key, lengths, th.flip_margin).items():
            rows[e][FINDINGS] += found
    return cameras
