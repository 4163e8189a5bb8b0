"""Zarr replay buffers written by zarr itself, step for step as diffusion policy's `ReplayBuffer` writes them.

The layout and the writing sequence follow real-stanford/diffusion_policy, its module
diffusion_policy.common.replay_buffer (commit 02373793ac4d0f63582c20fe1cff76034837edb5): `create_empty_zarr` makes
groups ``data`` and ``meta`` and an empty int64 ``meta/episode_ends`` without a compressor; `add_episode` creates
each ``data/<key>`` array at the first episode (zeros, time-chunked, Blosc lz4 level 5 without shuffle: its
"default" compressor), then for every episode resizes each array by the episode's rows, assigns them to the tail,
and appends the new total row count to ``episode_ends``. diffusion_policy targets zarr 2; zarr 3 writes the same v2
store here (``zarr_format=2``). UMI builds its buffer that way, then `save_to_store`s it into a `zarr.ZipStore`
(``*.zarr.zip``): every array copied whole with its chunks and compressor (`zip_store=True`).
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import zarr

Episode = dict[str, npt.NDArray[np.generic]]


def write_replay_buffer(path: Path, episodes: list[Episode], *, zip_store: bool = False, chunk: int = 4) -> Path:
    """`episodes` (key -> rows) appended one by one into a new replay buffer at `path`."""
    import numcodecs

    built = path.with_name(path.name + ".building") if zip_store else path
    root: Any = zarr.open_group(str(built), mode="w", zarr_format=2)
    data = root.require_group("data")
    meta = root.require_group("meta")
    ends = meta.zeros(name="episode_ends", shape=(0,), dtype=np.int64, compressor=None)
    compressor = numcodecs.Blosc(cname="lz4", clevel=5, shuffle=numcodecs.Blosc.NOSHUFFLE)
    total = 0
    for episode in episodes:
        length = len(next(iter(episode.values())))
        total += length
        for key, rows in episode.items():
            if key not in data:
                arr = data.zeros(
                    name=key,
                    shape=(total, *rows.shape[1:]),
                    chunks=(chunk, *rows.shape[1:]),
                    dtype=rows.dtype,
                    compressor=compressor,
                )
            else:
                arr = data[key]
                arr.resize((total, *rows.shape[1:]))
            arr[-length:] = rows
        ends.resize((ends.shape[0] + 1,))
        ends[-1] = total
    if zip_store:
        _save_to_zip(root, path)
        shutil.rmtree(built)
    return path


def _save_to_zip(root: Any, path: Path) -> None:
    """UMI's `save_to_store(zarr.ZipStore(path, mode="w"))`: meta and data arrays copied with their chunks and
    compressors."""
    store = zarr.storage.ZipStore(path, mode="w")
    out = zarr.open_group(store, mode="w", zarr_format=2)
    for group in ("meta", "data"):
        dst = out.require_group(group)
        for key, arr in root[group].arrays():
            dst.create_array(key, data=arr[:], chunks=arr.chunks, compressors=arr.compressors or None)
    store.close()


def write_umi_buffer(path: Path, episodes: list[Episode], image_key: str = "camera0_rgb", level: int = 99) -> Path:
    """A UMI-style ``*.zarr.zip``: as real-stanford/universal_manipulation_interface's
    script 07_generate_replay_buffer (in scripts_slam_pipeline, commit b310553afd7540b2ee6c32f62da5d41a97320501) makes
    one: the low-dimensional arrays added episode by episode, then each ``camera<i>_rgb`` array created at its
    full length with one frame a chunk and imagecodecs' JPEG-XL compressor (``JpegXl(level, numthreads=1)``,
    registered with numcodecs), its frames assigned one by one, and the buffer saved into a `zarr.ZipStore`.
    `image_key` of each episode holds its frames."""
    from imagecodecs.numcodecs import Jpegxl, register_codecs

    register_codecs(verbose=False)
    built = path.with_name(path.name + ".building")
    lowdim = [{k: v for k, v in ep.items() if k != image_key} for ep in episodes]
    write_replay_buffer(built, lowdim)
    root: Any = zarr.open_group(str(built), mode="a")
    frames = np.concatenate([ep[image_key] for ep in episodes])
    images = root["data"].create_array(
        image_key, shape=frames.shape, chunks=(1, *frames.shape[1:]), dtype=np.uint8,
        compressors=Jpegxl(level=level, numthreads=1),
    )  # fmt: skip
    for i, frame in enumerate(frames):
        images[i] = frame
    _save_to_zip(root, path)
    shutil.rmtree(built)
    return path


def umi_episodes(
    lengths: tuple[int, ...] = (5, 3, 7), seed: int = 0, size: tuple[int, int] = (36, 48)
) -> list[Episode]:
    """One gripper's episodes with UMI's own key set and dtypes, as (commit d095ba9590df789df5189eea5ee7e431689038a6)
    real-stanford/universal_manipulation_interface:scripts_slam_pipeline/07_generate_replay_buffer.py fills
    `episode_data`: ``camera0_rgb`` (uint8 HxWx3), ``robot0_eef_pos`` and ``robot0_eef_rot_axis_angle`` (float32
    [3], the TCP pose), ``robot0_gripper_width`` (float32 [1]), ``robot0_demo_start_pose`` and
    ``robot0_demo_end_pose`` (the demonstration's start and end pose on every row, in the pose's own dtype:
    float64 [6]). No ``action``: UMI's training code derives it. Poses and widths are random walks, pictures
    random."""
    rng = np.random.default_rng(seed)
    out: list[Episode] = []
    for n in lengths:
        pose = np.cumsum(rng.normal(0.0, 0.01, (n, 6)), axis=0) + rng.normal(0.0, 0.3, 6)
        width = np.clip(0.05 + np.cumsum(rng.normal(0.0, 0.002, n)), 0.0, 0.1)
        out.append({
            "camera0_rgb": rng.integers(0, 256, (n, *size, 3), dtype=np.uint8),
            "robot0_eef_pos": pose[:, :3].astype(np.float32),
            "robot0_eef_rot_axis_angle": pose[:, 3:].astype(np.float32),
            "robot0_gripper_width": width[:, None].astype(np.float32),
            "robot0_demo_start_pose": np.repeat(pose[:1], n, axis=0),
            "robot0_demo_end_pose": np.repeat(pose[-1:], n, axis=0),
        })  # fmt: skip
    return out


def sample_episodes(lengths: tuple[int, ...] = (5, 3, 7), seed: int = 0) -> list[Episode]:
    """A pusht-like buffer: an 8x6 RGB image, a 5-d float32 state, a 2-d action, an int keypoint count."""
    rng = np.random.default_rng(seed)
    return [
        {
            "img": rng.integers(0, 256, (n, 8, 6, 3), dtype=np.uint8),
            "state": rng.standard_normal((n, 5)).astype(np.float32),
            "action": rng.standard_normal((n, 2)).astype(np.float32),
            "n_contacts": rng.integers(0, 4, (n,), dtype=np.int64),
        }
        for n in lengths
    ]


def _edit(path: Path, rel: str, **changes: object) -> None:
    doc = path / rel
    meta = json.loads(doc.read_text())
    meta.update(changes)
    doc.write_text(json.dumps(meta))


def _missing_ends(p: Path) -> None:
    shutil.rmtree(p / "meta/episode_ends")


def _ragged(p: Path) -> None:
    _edit(p, "data/state/.zarray", shape=[10, 5])  # 10 rows of 15 the episodes end at


def _text_dtype(p: Path) -> None:
    root: Any = zarr.open_group(str(p), mode="a")
    root["data"].create_array("label", shape=(15,), dtype="<U4", compressors=None)


def _huge(p: Path) -> None:
    _edit(p, "data/img/.zarray", shape=[15, 100000, 100000, 3], chunks=[4, 100000, 100000, 3])


def _falling_ends(p: Path) -> None:
    ends: Any = zarr.open_group(str(p), mode="a")["meta/episode_ends"]
    ends[1] = 2


def _codec(p: Path) -> None:
    _edit(p, "data/img/.zarray", compressor={"id": "vendor_secret_codec"})


def corrupt_chunk(p: Path) -> None:
    """A chunk of data/state that is not Blosc data (found only when its rows are read)."""
    (p / "data/state/0.0").write_bytes(b"\x02\x01garbage")


# damage -> what the one-line refusal says (after the store's path)
DAMAGES: dict[str, tuple[Callable[[Path], None], str]] = {
    "missing-episode-ends": (_missing_ends, r"meta/episode_ends: missing"),
    "ragged": (_ragged, r"data/state: 10 rows, but meta/episode_ends ends at row 15"),
    "text-dtype": (_text_dtype, r"data/label: dtype .* is not numeric"),
    "huge-shape": (_huge, r"data/img: declares \d+ bytes per step or chunk"),
    "falling-ends": (_falling_ends, r"meta/episode_ends: entry 1 \(2\) is not above"),
    "unknown-codec": (_codec, r"data: .*codec 'vendor_secret_codec' is not available"),
}


def replace_chunk(store: Path, compressor: dict[str, Any], chunk: bytes | None) -> Path:
    """`store`'s data/action recompressed with `compressor` (its .zarray and every chunk), then its chunk 0.0
    replaced by `chunk` (None: a FIFO): a chunk that lies about its size, a bomb, a file zarr would wait on."""
    import os

    import numcodecs

    meta = store / "data/action/.zarray"
    meta.write_text(json.dumps({**json.loads(meta.read_text()), "compressor": compressor}))
    codec = numcodecs.get_codec(dict(compressor))
    for other in (store / "data/action").glob("*.0"):  # the other chunks: good data in the new compressor
        other.write_bytes(codec.encode(numcodecs.Blosc().decode(other.read_bytes())))
    target = store / "data/action/0.0"
    target.unlink()
    if chunk is None:
        os.mkfifo(target)
    else:
        target.write_bytes(chunk)
    return store
