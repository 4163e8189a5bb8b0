"""`view`: one episode of a LeRobot v3 dataset (or an MCAP file, or a rosbag2 folder holding one) in rerun.

Cameras are logged once as `AssetVideo` plus one `VideoFrameReference` per row, and nothing is decoded. v3
packs many episodes into one mp4, so the episode's packets — from `from_timestamp` to `to_timestamp` — are
remuxed into a clip of their own (frame k at k / fps); if the episode does not start on a keyframe, the whole
file is logged and frame k is referenced at `from_timestamp + k / fps`; a `dtype: image` camera logs each frame's
embedded PNG/JPEG, a segmentation mask (`is_segmentation_mask`) one `SegmentationImage` per row under an
`AnnotationContext` naming its ids; a depth video (`is_depth_map`) is decoded into one `DepthImage`
(millimetres) per row.
State, action and `observation.environment_state` become one scalar series per dimension named after the
contract (or info.json's names), the task is a text document, reward/success/done are series with a text event
at the end, and replay results (see `formats/results.py`) add per-step action error and divergence.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import rerun as rr

from openral_data import manifests
from openral_data.errors import (
    DatasetError,
    EpisodeSelectionError,
    NotFound,
    OutputExists,
    ResultsError,
    UsageError,
    WriteError,
)
from openral_data.formats import results as results_layout
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.clip import episode_clip
from openral_data.formats.lerobot_v3.features import ACTION, STATE
from openral_data.formats.lerobot_v3.frames import decode_episode_video, depth_settings, video_span
from openral_data.formats.lerobot_v3.images import ENVIRONMENT_STATE, image_bytes, image_keys, media_type
from openral_data.formats.lerobot_v3.layout import FilePos
from openral_data.formats.lerobot_v3.masks import MASK_IDS, decode_mask, is_mask
from openral_data.formats.lerobot_v3.missing import missing_files
from openral_data.formats.lerobot_v3.success import EPISODE_SUCCESS, episode_successes
from openral_data.formats.mcap.chunks import check_mcap
from openral_data.formats.mcap.summary import check_summary
from openral_data.formats.parquetfile import read_table
from openral_data.metrics.sources import DatasetSource, open_dataset
from openral_data.viz.entities import (
    APP_ID,
    FRAME,
    OUTCOMES,
    TASK,
    TIME,
    camera_entity,
    log_episode_end,
    log_outcome_style,
    log_series_styles,
    outcome_entity,
    series_entities,
)
from openral_data.viz.rrd_file import RrdFile


@dataclass(frozen=True)
class ViewOptions:
    path: Path
    episode: int = 0
    save: Path | None = None
    results: Path | None = None


def has_display() -> bool:
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def run_view(opts: ViewOptions) -> str:
    """Log the episode; returns a one-line description of where it went."""
    if not opts.path.exists():
        raise NotFound(f"{opts.path}: no such file or directory")
    mcap = None if (opts.path / layout.INFO_PATH).is_file() else mcap_file(opts.path)
    is_mcap = mcap is not None
    if mcap is None and not (opts.path / layout.INFO_PATH).is_file():
        raise DatasetError(
            f"{opts.path}: neither a LeRobot v3 dataset (meta/info.json), an .mcap file nor a rosbag2 folder",
            code="dataset.invalid",
        )
    save = opts.save
    if save is None and not has_display():
        name = opts.path.stem if is_mcap else f"{opts.path.name}-episode-{opts.episode}"
        save = manifests.datasets_dir() / f"{name}.rrd"  # beside the outputs (git-ignored), not in the cwd
    if save is not None:
        if save.suffix != ".rrd":
            raise UsageError(f"{save}: --save writes an .rrd file")
        if save.exists():
            raise OutputExists(f"{save}: exists; refusing to overwrite it")
    # everything that can be wrong with the inputs is found before anything is written
    if mcap is not None:
        check_mcap(mcap)  # rerun's loader would decompress a chunk bomb without bound
        check_summary(mcap)  # rerun would only log its refusal, and an empty recording be "saved"
    episode = None if is_mcap else load_episode(open_dataset(opts.path), opts.episode, opts.results)
    rec = rr.RecordingStream(APP_ID)
    if save is not None:
        with RrdFile(rec, save):
            what = _log(rec, opts, mcap, episode)
        return f"saved {what} to {save}"
    rec.spawn()
    try:
        what = _log(rec, opts, mcap, episode)
        rec.flush(timeout_sec=VIEWER_FLUSH)
    except RuntimeError as exc:  # the viewer went away or did not take the recording in time
        raise WriteError(f"the rerun viewer: cannot write the recording: {exc}") from exc
    finally:
        rec.disconnect()
    return f"opened {what} in the rerun viewer"


VIEWER_FLUSH = 60.0  # s a spawned viewer may take to receive what was logged


def _log(rec: rr.RecordingStream, opts: ViewOptions, mcap: Path | None, episode: EpisodeData | None) -> str:
    """Log the MCAP file or the episode into `rec`; what was logged, for the summary line."""
    if episode is None:
        assert mcap is not None  # no episode is loaded only for an MCAP file
        rec.log_file_from_path(mcap)
        return f"{opts.path}"
    log_episode(rec, episode)
    return f"{opts.path} episode {opts.episode} ({episode.frames.num_rows} frames)"


def mcap_file(path: Path) -> Path | None:
    """The MCAP file `view` shows for `path`: an ``.mcap`` file itself, or the one ``.mcap`` of a rosbag2 folder
    (``metadata.yaml`` beside it, as `record --format mcap` and ``ros2 bag record`` write); None otherwise."""
    if path.is_file():
        return path if path.suffix.lower() == ".mcap" else None
    if not (path / "metadata.yaml").is_file():
        return None
    found = sorted(p for p in path.iterdir() if p.suffix.lower() == ".mcap" and p.is_file() and not p.is_symlink())
    if len(found) != 1:
        held = ", ".join(p.name for p in found) or "none"
        raise DatasetError(
            f"{path}: a rosbag2 folder: view needs exactly one .mcap file in it (found: {held}); "
            "pass the .mcap to show",
            code="dataset.invalid",
        )
    return found[0]


@dataclass(frozen=True)
class EpisodeData:
    ds: DatasetSource
    row: dict[str, Any]  # the episode's meta/episodes row (without stats)
    frames: pa.Table  # its data rows, in order
    videos: dict[str, Path]  # camera key -> mp4
    steps: pa.Table | None  # replay/eval steps of this episode


def load_episode(ds: DatasetSource, episode: int, results: Path | None = None) -> EpisodeData:
    row = _episode_row(ds, episode)
    # a partial download: the files this episode needs, named in one line with the command that fetches them
    missing_files(ds.root, ds.info, [row], ds.cameras).need(None, ds.cameras, "view")
    frames = _episode_frames(ds, row)
    videos = {cam: _video_path(ds, row, cam) for cam in ds.cameras}
    steps = None
    if results is not None:
        res = results_layout.open_results(results)
        steps = read_table(res.steps_path, filters=[("episode_index", "=", episode)]).sort_by("frame_index")
        if steps.num_rows == 0:
            raise ResultsError(f"{res.steps_path}: no steps for episode {episode}")
    return EpisodeData(ds, row, frames, videos, steps)


def _video_path(ds: DatasetSource, row: dict[str, Any], cam: str) -> Path:
    chunk, file = row.get(f"videos/{cam}/chunk_index"), row.get(f"videos/{cam}/file_index")
    if chunk is None or file is None:
        raise DatasetError(
            f"{ds.root}: meta/episodes: videos/{cam}/chunk_index: missing for episode {row['episode_index']}",
            code="dataset.invalid",
        )
    path = layout.template_path(ds.root, ds.info, "video_path", FilePos(int(chunk), int(file)), video_key=cam)
    if not path.is_file():
        raise DatasetError(f"{path}: missing (video of episode {row['episode_index']})", code="dataset.incomplete")
    return path


def _episode_row(ds: DatasetSource, episode: int) -> dict[str, Any]:
    tables = (
        [ds.episodes_table.filter(pc.equal(ds.episodes_table.column("episode_index"), episode))]
        if ds.episodes_table is not None  # a v2.x dataset's, from meta/episodes.jsonl
        else (read_table(f, filters=[("episode_index", "=", episode)]) for f in ds.episode_files)
    )
    for table in tables:
        if table.num_rows:
            drop = [c for c in table.column_names if c.startswith("stats/")]
            row: dict[str, Any] = table.drop_columns(drop).to_pylist()[0]
            return row
    total = ds.info.get("total_episodes", "?")
    raise EpisodeSelectionError(f"--episode: {episode} not in {ds.root} ({total} episodes)", code="episodes.range")


def _episode_frames(ds: DatasetSource, row: dict[str, Any]) -> pa.Table:
    pos = FilePos(int(row["data/chunk_index"]), int(row["data/file_index"]))
    path = layout.template_path(ds.root, ds.info, "data_path", pos)
    if not path.is_file():
        raise DatasetError(f"{path}: missing (data of episode {row['episode_index']})", code="dataset.incomplete")
    table = read_table(path, filters=[("episode_index", "=", int(row["episode_index"]))])
    if table.num_rows == 0:
        raise DatasetError(f"{path}: no rows for episode {row['episode_index']}", code="dataset.invalid")
    for name in ("frame_index", "timestamp"):  # the timelines: rerun takes neither a missing nor a NaN time
        values = table.column(name).to_numpy(zero_copy_only=False) if name in table.column_names else None
        if values is None or not np.isfinite(np.asarray(values, dtype=np.float64)).all():
            raise DatasetError(
                f"{path}: {name}: missing or not finite in episode {row['episode_index']}", code="dataset.invalid"
            )
    order = "index" if "index" in table.column_names else "frame_index"
    return table.sort_by(order)


def _matrix(table: pa.Table, key: str) -> np.ndarray[Any, np.dtype[np.float64]]:
    col = table.column(key).combine_chunks()
    if pa.types.is_list(col.type) or pa.types.is_fixed_size_list(col.type) or pa.types.is_large_list(col.type):
        flat = np.asarray(col.flatten().to_numpy(zero_copy_only=False), dtype=np.float64)
        return flat.reshape(len(col), -1)
    return np.asarray(col.to_numpy(zero_copy_only=False), dtype=np.float64).reshape(-1, 1)


def log_episode(rec: rr.RecordingStream, data: EpisodeData) -> None:
    ds, row, table = data.ds, data.row, data.frames
    episode = int(row["episode_index"])
    frame_index = np.asarray(table.column("frame_index").to_numpy(), dtype=np.int64)
    ts = np.asarray(table.column("timestamp").to_numpy(), dtype=np.float64)
    times = [rr.TimeColumn(FRAME, sequence=frame_index), rr.TimeColumn(TIME, duration=ts)]

    tasks = row.get("tasks") or []
    rec.log(TASK, rr.TextDocument("\n".join(tasks) or "(no task)"), static=True)
    for cam, path in data.videos.items():
        _log_camera(rec, ds, row, cam, path, frame_index, times)
    for key in image_keys(ds.info):
        if key in table.column_names and is_mask(ds.info["features"][key]):
            _log_masks(rec, table, key, ds.info["features"][key], frame_index, ts)
        elif key in table.column_names:
            _log_images(rec, table, key, frame_index, ts)
    for key, base in ((STATE, "state"), (ACTION, "action"), (ENVIRONMENT_STATE, "environment_state")):
        if key not in table.column_names:
            continue
        values = _matrix(table, key)
        series = series_entities(base, ds.dim_names(key), values.shape[1])
        log_series_styles(rec, series)
        for i, (entity, _) in enumerate(series):
            rec.send_columns(entity, indexes=times, columns=rr.Scalars.columns(scalars=values[:, i]))
    for name in OUTCOMES:
        if f"next.{name}" in table.column_names:
            values = np.asarray(table.column(f"next.{name}").to_numpy(zero_copy_only=False), dtype=np.float64)
            log_outcome_style(rec, name)
            rec.send_columns(outcome_entity(name), indexes=times, columns=rr.Scalars.columns(scalars=values))
    success = episode_successes(ds.root, pa.Table.from_pylist([_success_fields(row)])).get(episode)
    rec.set_time(FRAME, sequence=int(frame_index[-1]))
    rec.set_time(TIME, duration=float(ts[-1]))
    log_episode_end(rec, episode, success)
    if data.steps is not None:
        _log_results(rec, data.steps, ts, frame_index)


def _log_masks(
    rec: rr.RecordingStream,
    table: pa.Table,
    key: str,
    feature: dict[str, Any],
    frame_index: np.ndarray[Any, np.dtype[np.int64]],
    ts: np.ndarray[Any, np.dtype[np.float64]],
) -> None:
    """A segmentation mask (formats/lerobot_v3/masks.py): one SegmentationImage per row, its ids named by an
    annotation context."""
    entity = camera_entity(key)
    ids = feature["info"].get(MASK_IDS)
    if isinstance(ids, dict):
        labels = [(int(i), str(name)) for i, name in ids.items() if str(i).isdigit()]
        rec.log(entity, rr.AnnotationContext(labels), static=True)
    for k, cell in enumerate(table.column(key).to_pylist()):
        mask = decode_mask(cell, f"{key}: frame {int(frame_index[k])}")
        rec.set_time(FRAME, sequence=int(frame_index[k]))
        rec.set_time(TIME, duration=float(ts[k]))
        rec.log(entity, rr.SegmentationImage(mask))


def _log_images(
    rec: rr.RecordingStream,
    table: pa.Table,
    key: str,
    frame_index: np.ndarray[Any, np.dtype[np.int64]],
    ts: np.ndarray[Any, np.dtype[np.float64]],
) -> None:
    """A `dtype: image` camera: each frame's embedded PNG/JPEG logged as it is (rerun decodes it)."""
    entity = camera_entity(key)
    for k, cell in enumerate(table.column(key).to_pylist()):
        data = image_bytes(cell, f"{key}: frame {int(frame_index[k])}")
        rec.set_time(FRAME, sequence=int(frame_index[k]))
        rec.set_time(TIME, duration=float(ts[k]))
        rec.log(entity, rr.EncodedImage(contents=data, media_type=media_type(data)))


def _success_fields(row: dict[str, Any]) -> dict[str, Any]:
    """The columns of the episode's row that the success rule reads."""
    return {k: row[k] for k in ("episode_index", EPISODE_SUCCESS) if k in row}


def _log_depth(
    rec: rr.RecordingStream,
    ds: DatasetSource,
    row: dict[str, Any],
    cam: str,
    frame_index: np.ndarray[Any, np.dtype[np.int64]],
) -> None:
    """A depth video (`is_depth_map`): decoded and dequantized as lerobot's loader does, one DepthImage per row
    (millimetres; rerun's video player does not show 12-bit depth)."""
    entity = camera_entity(cam)
    for k, mm in enumerate(decode_episode_video(ds.root, ds.info, row, cam)):
        rec.set_time(FRAME, sequence=int(frame_index[k]))
        rec.set_time(TIME, duration=float(frame_index[k]) / ds.fps)
        rec.log(entity, rr.DepthImage(mm, meter=1000.0))


def _log_camera(
    rec: rr.RecordingStream,
    ds: DatasetSource,
    row: dict[str, Any],
    cam: str,
    path: Path,
    frame_index: np.ndarray[Any, np.dtype[np.int64]],
    times: list[rr.TimeColumn],
) -> None:
    entity = camera_entity(cam)
    if depth_settings(ds.info, cam) is not None:
        _log_depth(rec, ds, row, cam, frame_index)
        return
    start, end = video_span(path, row, cam, len(frame_index), ds.fps)
    clip = episode_clip(path, start, end, ds.fps)
    if clip.frames != len(frame_index):  # cut short: rerun would show blank frames; more: another episode's
        raise DatasetError(
            f"{path}: {cam}: holds {clip.frames} frames in the episode's range, its data {len(frame_index)} rows",
            code="dataset.invalid",
        )
    if clip.data is not None:  # only this episode's packets, remuxed: the .rrd does not carry the whole file
        rec.log(entity, rr.AssetVideo(contents=clip.data, media_type="video/mp4"), static=True)
    else:
        rec.log(entity, rr.AssetVideo(path=path), static=True)
    nanos = np.round((clip.start + frame_index / ds.fps) * 1e9).astype(np.int64)
    rec.send_columns(entity, indexes=times, columns=rr.VideoFrameReference.columns_nanos(nanos))


def _log_results(
    rec: rr.RecordingStream,
    steps: pa.Table,
    ts: np.ndarray[Any, np.dtype[np.float64]],
    frame_index: np.ndarray[Any, np.dtype[np.int64]],
) -> None:
    fi = np.asarray(steps.column("frame_index").to_numpy(), dtype=np.int64)
    lookup = {int(frame_index[k]): float(ts[k]) for k in range(len(frame_index))}
    t = np.array([lookup.get(int(f), np.nan) for f in fi])
    ok = ~np.isnan(t)
    idx = [rr.TimeColumn(FRAME, sequence=fi[ok]), rr.TimeColumn(TIME, duration=t[ok])]
    for key in ("action_error", "divergence"):
        values = np.asarray(steps.column(key).to_numpy(zero_copy_only=False), dtype=np.float64)[ok]
        rec.log(f"replay/{key}", rr.SeriesLines(names=key), static=True)
        rec.send_columns(f"replay/{key}", indexes=idx, columns=rr.Scalars.columns(scalars=values))
