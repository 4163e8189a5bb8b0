"""An episode's frames read back from a LeRobot v3 dataset: numeric columns from its data parquet, images decoded
with PyAV from each camera's mp4 starting at the episode's ``from_timestamp`` (a `dtype: image` camera: from the
PNG/JPEG embedded in the parquet; a depth video, `is_depth_map`: as (H, W) uint16 millimetres, the way lerobot's
loader dequantizes it). Works on any LeRobot v3 dataset."""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, NoReturn

import av
import numpy as np
import numpy.typing as npt
import pyarrow as pa
import pyarrow.compute as pc
from av.container import InputContainer
from av.video.stream import VideoStream

from openral_data.errors import DatasetError, SparseGap, VideoEnds
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.depth import DepthSettings, decode_codes
from openral_data.formats.lerobot_v3.features import camera_key, camera_keys
from openral_data.formats.lerobot_v3.images import ENVIRONMENT_STATE, decode_image, image_keys
from openral_data.formats.lerobot_v3.masks import decode_mask, is_mask
from openral_data.formats.lerobot_v3.sparse import sparse_frames
from openral_data.formats.lerobot_v3.variants import feature_info, is_depth
from openral_data.formats.parquetfile import read_table
from openral_data.paths import regular_file
from openral_data.types import Frame, FrameColumn


def episode_frames(
    src: Path, info: dict[str, Any], row: dict[str, Any], tasks: list[str], cameras: list[str],
    columns: Sequence[FrameColumn] = (),
) -> Iterator[Frame]:  # fmt: skip
    """Episode `row` frame by frame; `cameras` are camera names (`features.camera_keys`), in the order wanted;
    `columns` the per-frame features to hand on in `Frame.columns` (a float32 vector, or a bool as shape [1])."""
    e = int(row["episode_index"])
    path = layout.template_path(src, info, "data_path", layout.FilePos(row["data/chunk_index"], row["data/file_index"]))
    table = read_table(path)
    try:
        table = table.filter(pc.equal(table.column("episode_index"), e)).sort_by("frame_index")
    except (KeyError, pa.ArrowException) as exc:
        raise DatasetError(f"{path}: episode_index/frame_index: {exc}", code="dataset.invalid") from None
    n = int(row["length"])
    if table.num_rows != n:
        raise DatasetError(
            f"{path}: episode {e} has {table.num_rows} rows, meta/episodes says {n}", code="dataset.invalid"
        )
    cols = table.to_pydict()
    fps = int(info["fps"])
    stored = set(image_keys(info))  # pictures in the parquet; every other camera is a video
    keys = camera_keys(info["features"])
    key = {name: keys.get(name, camera_key(name)) for name in cameras}
    videos = {name: _decode_video(src, info, row, key[name], n, fps) for name in cameras if key[name] not in stored}
    pictures = {name: cols[key[name]] for name in cameras if key[name] in stored}
    masks = {name for name in pictures if is_mask(info["features"][key[name]])}  # uint16 ids, not RGB
    for i in range(n):
        images = {
            name: (decode_mask if name in masks else decode_image)(cells[i], f"{path}: {key[name]}: row {i}")
            for name, cells in pictures.items()
        }
        for name, it in videos.items():
            img = next(it, None)
            if img is None:
                raise DatasetError(
                    f"episode {e}: camera {name}: video ends before frame {i} of {n}", code="dataset.invalid"
                )
            images[name] = img
        images = {name: images[name] for name in cameras}  # in the caller's camera order
        yield Frame(
            state=np.asarray(cols["observation.state"][i], dtype=np.float32).reshape(-1),
            action=np.asarray(cols["action"][i], dtype=np.float32).reshape(-1),
            images=images,
            task=_task(tasks, int(cols["task_index"][i]), f"{path}: task_index", f"episode {e} row {i}"),
            reward=float(cols["next.reward"][i]) if "next.reward" in cols else 0.0,  # ignored: schema has no reward
            done=bool(cols["next.done"][i]) if "next.done" in cols else i == n - 1,
            success=bool(cols["next.success"][i]) if "next.success" in cols else False,  # likewise
            # LeRobot v3 stores frame_index / fps rounded to float32; the exact value keeps stamps on the grid
            timestamp=int(cols["frame_index"][i]) / fps,
            environment_state=(
                np.asarray(cols[ENVIRONMENT_STATE][i], dtype=np.float32).reshape(-1)
                if ENVIRONMENT_STATE in cols
                else None
            ),
            columns=_row_columns(cols, i, columns),
        )


def _task(tasks: list[str], task_index: int, where: str, row: str) -> str:
    """The text of `task_index` (a dataset without meta/tasks: ""); never another task's text, nor ""."""
    if task_index < 0 or (tasks and task_index >= len(tasks)):
        raise DatasetError(
            f"{where}: {task_index} at {row} is not in meta/tasks.parquet ({len(tasks)} task(s))",
            code="dataset.invalid",
        )
    return tasks[task_index] if tasks else ""


def _row_columns(cols: dict[str, list[Any]], i: int, columns: Sequence[FrameColumn]) -> dict[str, npt.NDArray[Any]]:
    """Row `i`'s values of the per-frame `columns`: a float32 vector, or a bool flag as shape [1]."""
    return {
        c.key: np.asarray(cols[c.key][i], dtype=np.float32 if c.dtype == "float32" else bool).reshape(-1)
        for c in columns
    }


def video_span(path: Path, row: dict[str, Any], key: str, n: int, fps: int) -> tuple[float, float]:
    """The seconds [from, to) of the `n`-frame episode of meta/episodes `row` in the mp4 of `key` at `path`
    (a missing value: from 0, to from + n / fps). `from` must be a finite number >= 0 and `to - from` be
    `n / fps` within half a frame; else a `DatasetError`: another episode's frames would pass as this one's."""
    start, end = row.get(f"videos/{key}/from_timestamp"), row.get(f"videos/{key}/to_timestamp")
    start = 0.0 if start is None else float(start)
    end = start + n / fps if end is None else float(end)
    if not (math.isfinite(start) and math.isfinite(end) and start >= 0 and abs(end - start - n / fps) <= 0.5 / fps):
        raise DatasetError(
            f"{path}: episode {row.get('episode_index')}: videos/{key}/from_timestamp..to_timestamp {start}..{end} "
            f"is not its {n} frames at {fps} fps",
            code="dataset.invalid",
        )
    return start, end


def depth_settings(info: dict[str, Any], key: str) -> DepthSettings | None:
    """The quantizer of feature `key` if it is a depth video (`is_depth_map` in its info, or lerobot's legacy
    spellings: `variants.is_depth`), else None."""
    feature = info["features"].get(key, {})
    return DepthSettings.from_info(feature_info(feature)) if is_depth(feature) else None


def _decode_video(
    src: Path, info: dict[str, Any], row: dict[str, Any], key: str, n: int, fps: int, wanted: int | Sequence[int] = 1,
    videos: OpenVideos | None = None,
) -> Iterator[npt.NDArray[Any]]:  # fmt: skip
    """The episode's `n` frames of `key` (`wanted`: every `wanted`-th, or those indices), decoded from its mp4
    starting at `from_timestamp` (`videos`: the mp4s kept open, else opened for this episode)."""
    pos = layout.FilePos(row[f"videos/{key}/chunk_index"], row[f"videos/{key}/file_index"])
    path = layout.template_path(src, info, "video_path", pos, video_key=key)
    start, _ = video_span(path, row, key, n, fps)
    try:
        yield from _decode(path, start, n, fps, depth_settings(info, key), wanted, videos)
    except (av.error.FFmpegError, OSError) as exc:  # missing, empty, truncated or not a video
        reason = getattr(exc, "strerror", None) or type(exc).__name__
        raise DatasetError(f"{path}: cannot decode video: {reason}", code="dataset.invalid") from None


def decode_episode_video(
    src: Path, info: dict[str, Any], row: dict[str, Any], key: str, stride: int = 1, videos: OpenVideos | None = None
) -> Iterator[npt.NDArray[Any]]:
    """The frames of video feature `key` in the episode of meta/episodes `row` (RGB, or depth in mm); with
    `stride` > 1 only frames 0, stride, 2*stride, … (only the packets they need decoded, where the stream allows).
    `videos`: a pass over many episodes keeps their mp4s open there (`OpenVideos`)."""
    yield from _decode_video(src, info, row, key, int(row["length"]), int(info["fps"]), stride, videos)


def decode_episode_frames(
    src: Path, info: dict[str, Any], row: dict[str, Any], key: str, wanted: Sequence[int],
    videos: OpenVideos | None = None,
) -> Iterator[npt.NDArray[Any]]:  # fmt: skip
    """Frames `wanted` (indices in the episode, ascending, each once; those past its length left out) of video
    feature `key` in the episode of meta/episodes `row`, in order, as `decode_episode_video` gives them: only the
    packets they need decoded where the stream allows, nothing after the last. A video that ends before the last
    raises `VideoEnds` after the frames it holds."""
    n = int(row["length"])
    yield from _decode_video(src, info, row, key, n, int(info["fps"]), [t for t in wanted if t < n], videos)


LEAD_S = 2.0  # how far before a span to seek again when its first frames were shown before the keyframe found


def _decode(
    path: Path, start: float, n: int, fps: int, depth: DepthSettings | None = None, wanted: int | Sequence[int] = 1,
    videos: OpenVideos | None = None,
) -> Iterator[npt.NDArray[Any]]:  # fmt: skip
    """Frames `wanted` (a stride, or indices) of the `n` at `fps` from `start` seconds in the mp4 at `path`."""

    def picture(frame: av.VideoFrame) -> npt.NDArray[Any]:
        if depth is not None:
            return depth.to_millimetres(decode_codes(frame))
        return np.asarray(frame.to_ndarray(format="rgb24"), dtype=np.uint8)

    want = range(0, n, wanted) if isinstance(wanted, int) else wanted
    until = n if isinstance(wanted, int) else (want[-1] + 1 if len(want) else 0)  # a stride: to the span's end
    if not until and not isinstance(wanted, int):
        return  # no frame wanted
    sparse = wanted > 1 if isinstance(wanted, int) else len(want) < n
    given = 0  # wanted frames handed on
    for seek in (start, start - LEAD_S) if sparse else ():  # only the packets wanted frames need (sparse.py)
        try:
            with _opened(path, max(0.0, seek), videos) as (container, stream):
                for frame in sparse_frames(container, stream, start, n, fps, wanted):
                    yield picture(frame)
                    given += 1
            return
        except SparseGap as gap:
            if given or seek <= 0 or f"frame {want[0] if len(want) else 0} " not in f"{gap} ":
                break  # the whole span, below (which also says how a damaged or short video ends)
    for seek in (start, start - LEAD_S, 0.0):  # earlier when the span's first frames were lost (below)
        with _opened(path, max(0.0, seek), videos) as (container, stream):
            tb = stream.time_base
            assert tb is not None
            count = 0
            for frame in container.decode(stream):
                if frame.pts is None or float(frame.pts * tb) < start - 0.5 / fps:
                    continue
                if count == 0 and float(frame.pts * tb) > start + 0.5 / fps and seek > 0:
                    break  # an open GOP's leading frames, shown before the keyframe found: they need the one before
                if given < len(want) and count == want[given]:
                    yield picture(frame)
                    given += 1
                count += 1
                if count == until:
                    return
            else:
                break
    _ended(path, count, n)


@contextmanager
def _opened(path: Path, start: float, videos: OpenVideos | None = None) -> Iterator[tuple[InputContainer, VideoStream]]:
    """The mp4 at `path` (a regular file: a FIFO would block PyAV for ever), its first video stream, sought to the
    keyframe at or before `start` seconds; from `videos` when given (kept open there), else opened here."""
    if videos is not None:
        with videos.opened(path, start) as opened:
            yield opened
        return
    with av.open(str(regular_file(path))) as container:
        yield container, _sought(path, container, start)


def _sought(path: Path, container: InputContainer, start: float) -> VideoStream:
    """`container`'s first video stream, sought to the keyframe at or before `start` seconds (0: not sought)."""
    if not container.streams.video:
        raise DatasetError(f"{path}: holds no video stream", code="dataset.invalid")
    stream = container.streams.video[0]
    tb = stream.time_base
    assert tb is not None
    if start > 0:
        container.seek(int(start / tb), stream=stream, backward=True, any_frame=False)
    return stream


MAX_OPEN = 16  # mp4s `OpenVideos` keeps open at once (the most recently used)


class OpenVideos:
    """The mp4s of a pass over many episodes, kept open and sought to each episode instead of opened again:
    opening one parses its whole index (about 30 ms for a 200 MB file of 64x64 frames, more than decoding the
    sampled frames of an episode). A seek resets the decoder, so what is decoded is what a fresh open decodes; a
    span from a file's start (nothing to seek) and a decode that failed get a fresh open. Use it as a context
    manager: it closes them."""

    def __init__(self) -> None:
        self.held: dict[Path, InputContainer] = {}  # the most recently used last

    @contextmanager
    def opened(self, path: Path, start: float) -> Iterator[tuple[InputContainer, VideoStream]]:
        container = self.held.pop(path, None)
        if container is None or start <= 0:
            if container is not None:
                container.close()
            container = av.open(str(regular_file(path)))
        self.held[path] = container
        while len(self.held) > MAX_OPEN:
            self.held.pop(next(iter(self.held))).close()
        try:
            yield container, _sought(path, container, start)
        except Exception:
            self.held.pop(path, None)
            container.close()
            raise

    def __enter__(self) -> OpenVideos:
        return self

    def __exit__(self, *exc: object) -> None:
        for container in self.held.values():
            container.close()
        self.held.clear()


def _ended(path: Path, count: int, n: int) -> NoReturn:
    raise VideoEnds(path, count, n)
