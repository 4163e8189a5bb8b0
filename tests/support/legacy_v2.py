"""Small LeRobot v2.0 / v2.1 datasets written the way lerobot 0.x wrote them (no lerobot needed: pyarrow + PyAV).

`write_v2(root, *, version="v2.1", lengths=LENGTHS, video=True, image=False, names_null=False, fps=10) -> root`
writes, under `root`:

- ``meta/info.json``: ``codebase_version`` `version`, the v2 ``data_path``/``video_path`` templates
  (`DATA_PATH`, `VIDEO_PATH`; ``video_path`` null without a video camera), ``total_chunks``, ``chunks_size``,
  ``total_videos``, ``splits``, and ``features`` with lerobot's per-frame columns (timestamp, frame_index,
  episode_index, index, task_index, each shape [1], names null). A video camera (`VIDEO_CAMERA`) carries an
  ``info`` block in v2.1 and a ``video_info`` block in v2.0; its names are ``["height", "width", "channel"]``.
  With `names_null`, ``action``'s names are null (as in many Hub datasets).
- ``meta/episodes.jsonl`` (``{"episode_index", "tasks", "length"}``) and ``meta/tasks.jsonl``
  (``{"task_index", "task"}``); episode e does task ``TASKS[e % 2]``.
- v2.1: ``meta/episodes_stats.jsonl`` (``{"episode_index", "stats": {feature: {min, max, mean, std, count}}}``,
  one line per episode, as lerobot's ``compute_episode_stats``: image/video stats of shape (3, 1, 1) in [0, 1]);
  v2.0: ``meta/stats.json`` only (dataset-wide min/max/mean/std, no count).
- ``data/chunk-000/episode_{e:06d}.parquet`` per episode (with the ``huggingface`` schema metadata lerobot's
  `datasets` wrote; an image camera (`IMAGE_CAMERA`, ``dtype: image``) as ``{bytes, path}`` PNG structs), and
  per video camera ``videos/chunk-000/{key}/episode_{e:06d}.mp4`` (h264, yuv420p, starting at timestamp 0).

`expected_episodes(lengths, *, video=True, image=False, fps=10)` gives what a reader must find, frame by frame, in the
shape of `tests.support.lerobot_written.loaded_episodes` (keys ``state``, ``action``, ``cam``, ``wrist``,
``task``, ``success``, ``env``) plus ``timestamp``/``frame_index``/``index``; ``cam`` pixels are what was
encoded (compare decoded video within `COLOUR_TOL`), ``wrist`` pixels are exact (PNG).
"""

from __future__ import annotations

import io
import json
from collections.abc import Sequence
from fractions import Fraction
from pathlib import Path
from typing import Any

import av
import numpy as np
import numpy.typing as npt
import pyarrow as pa
import pyarrow.parquet as pq
from PIL import Image

DATA_PATH = "data/chunk-{episode_chunk:03d}/episode_{episode_index:06d}.parquet"
VIDEO_PATH = "videos/chunk-{episode_chunk:03d}/{video_key}/episode_{episode_index:06d}.mp4"
CHUNKS_SIZE = 1000
LENGTHS = (5, 8, 3)
TASKS = ("Pick up the cube.", "Place the cube in the bowl.")
VIDEO_CAMERA = "observation.images.cam"
IMAGE_CAMERA = "observation.images.wrist"
VIDEO_SHAPE = (32, 32, 3)
IMAGE_SHAPE = (16, 24, 3)
NAMES = ["x", "y"]
COLOUR_TOL = 6  # h264 on a uniform grey frame: decoded within a few levels of what was encoded
Frame = dict[str, Any]
INDEX_COLUMNS = ("timestamp", "frame_index", "episode_index", "index", "task_index")


def grey(e: int, t: int) -> int:
    """The uniform grey level of the video camera in episode e, frame t."""
    return (40 + 30 * t + 50 * e) % 256


def video_pixels(e: int, t: int) -> npt.NDArray[np.uint8]:
    return np.full(VIDEO_SHAPE, grey(e, t), dtype=np.uint8)


def image_pixels(e: int, t: int) -> npt.NDArray[np.uint8]:
    """A gradient, different per episode and frame (PNG keeps it exactly)."""
    h, w, _ = IMAGE_SHAPE
    y, x = np.mgrid[0:h, 0:w]
    img = np.stack([x * 9 + t * 5, y * 7 + e * 40, np.full_like(x, 60 + 11 * t)], axis=-1)
    return (img % 256).astype(np.uint8)


def state(e: int, t: int) -> list[float]:
    return [0.5 * t, -1.0 * e + 0.25 * t]


def action(e: int, t: int) -> list[float]:
    return [0.5 * t + 0.125, 2.0 * e - 0.5]


def expected_episodes(
    lengths: Sequence[int] = LENGTHS, *, video: bool = True, image: bool = False, fps: int = 10
) -> list[list[Frame]]:
    """Every frame `write_v2` writes, grouped by episode (see the module docstring)."""
    out: list[list[Frame]] = []
    index = 0
    for e, n in enumerate(lengths):
        frames: list[Frame] = []
        for t in range(n):
            frames.append(
                {
                    "state": state(e, t),
                    "action": action(e, t),
                    "cam": video_pixels(e, t) if video else None,
                    "wrist": image_pixels(e, t) if image else None,
                    "task": TASKS[e % 2],
                    "success": None,
                    "env": None,
                    "timestamp": timestamps(n, fps)[t],
                    "frame_index": t,
                    "index": index,
                }
            )
            index += 1
        out.append(frames)
    return out


def timestamps(length: int, fps: int) -> list[float]:
    """The timestamps of an episode's frames as lerobot stored them (float32 of t / fps)."""
    return [float(np.float32(t / fps)) for t in range(length)]


def features(*, version: str, video: bool, image: bool, names_null: bool, fps: int) -> dict[str, dict[str, Any]]:
    """info.json's features, in lerobot 0.x's order (cameras first, then state/action, then the index columns)."""
    out: dict[str, dict[str, Any]] = {}
    if video:
        block = {
            "video.fps": float(fps),
            "video.height": VIDEO_SHAPE[0],
            "video.width": VIDEO_SHAPE[1],
            "video.channels": VIDEO_SHAPE[2],
            "video.codec": "h264",
            "video.pix_fmt": "yuv420p",
            "video.is_depth_map": False,
            "has_audio": False,
        }
        out[VIDEO_CAMERA] = {
            "dtype": "video",
            "shape": list(VIDEO_SHAPE),
            "names": ["height", "width", "channel"],
            "info" if version == "v2.1" else "video_info": block,
        }
    if image:
        out[IMAGE_CAMERA] = {"dtype": "image", "shape": list(IMAGE_SHAPE), "names": ["height", "width", "channel"]}
    out["observation.state"] = {"dtype": "float32", "shape": [2], "names": {"motors": NAMES}}
    out["action"] = {"dtype": "float32", "shape": [2], "names": None if names_null else {"motors": NAMES}}
    for key in INDEX_COLUMNS:
        out[key] = {"dtype": "float32" if key == "timestamp" else "int64", "shape": [1], "names": None}
    return out


def _hf_metadata(feats: dict[str, dict[str, Any]]) -> bytes:
    """The ``huggingface`` schema metadata `datasets` wrote into every v2 parquet (lerobot's hf features)."""
    hf: dict[str, Any] = {}
    for key, ft in feats.items():
        if ft["dtype"] == "video":
            continue
        if ft["dtype"] == "image":
            hf[key] = {"_type": "Image"}
        elif ft["shape"] == [1]:
            hf[key] = {"dtype": ft["dtype"], "_type": "Value"}
        else:
            hf[key] = {
                "feature": {"dtype": ft["dtype"], "_type": "Value"},
                "length": ft["shape"][0],
                "_type": "Sequence",
            }
    return json.dumps({"info": {"features": hf}}).encode()


def _png(img: npt.NDArray[np.uint8]) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(img).save(buf, format="PNG")
    return buf.getvalue()


def _episode_table(e: int, n: int, first: int, fps: int, feats: dict[str, dict[str, Any]], image: bool) -> pa.Table:
    columns: dict[str, pa.Array] = {}
    if image:
        cells = [{"bytes": _png(image_pixels(e, t)), "path": f"frame_{t:06d}.png"} for t in range(n)]
        columns[IMAGE_CAMERA] = pa.array(cells, pa.struct([("bytes", pa.binary()), ("path", pa.string())]))
    vec = pa.list_(pa.float32(), 2)
    columns["observation.state"] = pa.array([state(e, t) for t in range(n)], vec)
    columns["action"] = pa.array([action(e, t) for t in range(n)], vec)
    columns["timestamp"] = pa.array(timestamps(n, fps), pa.float32())
    columns["frame_index"] = pa.array(range(n), pa.int64())
    columns["episode_index"] = pa.array([e] * n, pa.int64())
    columns["index"] = pa.array(range(first, first + n), pa.int64())
    columns["task_index"] = pa.array([e % 2] * n, pa.int64())
    table = pa.table(columns)
    return table.replace_schema_metadata({b"huggingface": _hf_metadata(feats)})


def _encode(path: Path, frames: list[npt.NDArray[np.uint8]], fps: int) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with av.open(str(path), "w") as out:
        stream = out.add_stream("libx264", rate=fps)
        stream.width, stream.height = VIDEO_SHAPE[1], VIDEO_SHAPE[0]
        stream.pix_fmt = "yuv420p"
        stream.time_base = Fraction(1, fps)
        stream.options = {"g": "2", "crf": "10"}
        for t, img in enumerate(frames):
            frame = av.VideoFrame.from_ndarray(img, format="rgb24")
            frame.pts = t
            out.mux(stream.encode(frame))
        out.mux(stream.encode(None))


def _stats(values: npt.NDArray[Any], *, picture: bool, count: bool) -> dict[str, Any]:
    """lerobot's `get_feature_stats`: per-dimension min/max/mean/std (pictures: per channel, shape (3, 1, 1), on
    channel-first floats in [0, 1])."""
    if picture:
        arr = values.transpose(0, 3, 1, 2).astype(np.float64) / 255.0
        axes: tuple[int, ...] = (0, 2, 3)
        keep = True
    else:
        arr = values.astype(np.float64).reshape(len(values), -1)
        axes, keep = (0,), False
    stats = {
        "min": np.min(arr, axis=axes, keepdims=keep),
        "max": np.max(arr, axis=axes, keepdims=keep),
        "mean": np.mean(arr, axis=axes, keepdims=keep),
        "std": np.std(arr, axis=axes, keepdims=keep),
    }
    out: dict[str, Any] = {k: (v[0] if picture else v).tolist() for k, v in stats.items()}
    if count:
        out["count"] = [len(values)]
    return out


def _picture(ft: dict[str, Any]) -> bool:
    return bool(ft["dtype"] in ("video", "image"))


def _feature_values(table: pa.Table, key: str, ft: dict[str, Any], e: int) -> npt.NDArray[Any]:
    if ft["dtype"] == "video":
        return np.stack([video_pixels(e, t) for t in range(table.num_rows)])
    if ft["dtype"] == "image":
        return np.stack([image_pixels(e, t) for t in range(table.num_rows)])
    return np.asarray(table.column(key).to_pylist())


def write_v2(
    root: Path,
    *,
    version: str = "v2.1",
    lengths: Sequence[int] = LENGTHS,
    video: bool = True,
    image: bool = False,
    names_null: bool = False,
    fps: int = 10,
) -> Path:
    """A v2.0/v2.1 dataset at `root` (see the module docstring); returns `root`."""
    assert version in ("v2.0", "v2.1"), version
    feats = features(version=version, video=video, image=image, names_null=names_null, fps=fps)
    (root / "meta").mkdir(parents=True, exist_ok=True)
    tables: list[pa.Table] = []
    first = 0
    for e, n in enumerate(lengths):
        table = _episode_table(e, n, first, fps, feats, image)
        path = root / DATA_PATH.format(episode_chunk=e // CHUNKS_SIZE, episode_index=e)
        path.parent.mkdir(parents=True, exist_ok=True)
        pq.write_table(table, path)
        if video:
            rel = VIDEO_PATH.format(episode_chunk=e // CHUNKS_SIZE, video_key=VIDEO_CAMERA, episode_index=e)
            _encode(root / rel, [video_pixels(e, t) for t in range(n)], fps)
        tables.append(table)
        first += n
    _write_meta(root, version, lengths, feats, tables, fps)
    return root


def _jsonl(path: Path, rows: list[dict[str, Any]]) -> None:
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))


def _write_meta(
    root: Path,
    version: str,
    lengths: Sequence[int],
    feats: dict[str, dict[str, Any]],
    tables: list[pa.Table],
    fps: int,
) -> None:
    n_eps = len(lengths)
    cameras = sum(1 for ft in feats.values() if ft["dtype"] == "video")
    info = {
        "codebase_version": version,
        "robot_type": "koch",
        "total_episodes": n_eps,
        "total_frames": sum(lengths),
        "total_tasks": min(n_eps, len(TASKS)),
        "total_videos": n_eps * cameras,
        "total_chunks": max(1, -(-n_eps // CHUNKS_SIZE)),
        "chunks_size": CHUNKS_SIZE,
        "fps": fps,
        "splits": {"train": f"0:{n_eps}"},
        "data_path": DATA_PATH,
        "video_path": VIDEO_PATH if cameras else None,
        "features": feats,
    }
    (root / "meta" / "info.json").write_text(json.dumps(info, indent=4))
    _jsonl(root / "meta" / "tasks.jsonl", [{"task_index": i, "task": TASKS[i]} for i in range(min(n_eps, 2))])
    _jsonl(
        root / "meta" / "episodes.jsonl",
        [{"episode_index": e, "tasks": [TASKS[e % 2]], "length": n} for e, n in enumerate(lengths)],
    )
    if version == "v2.1":
        rows = [
            {
                "episode_index": e,
                "stats": {
                    k: _stats(_feature_values(t, k, ft, e), picture=_picture(ft), count=True) for k, ft in feats.items()
                },
            }
            for e, t in enumerate(tables)
        ]
        _jsonl(root / "meta" / "episodes_stats.jsonl", rows)
        return
    whole = {
        k: _stats(
            np.concatenate([_feature_values(t, k, ft, e) for e, t in enumerate(tables)]),
            picture=_picture(ft),
            count=False,
        )
        for k, ft in feats.items()
    }
    (root / "meta" / "stats.json").write_text(json.dumps(whole, indent=4))
