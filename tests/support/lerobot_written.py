"""A small dataset written by lerobot 0.6.1 itself (no openral columns): three episodes, one video camera; on
request also a `dtype: image` camera (`IMAGE_CAMERA`, pixels `image_pixels(e, t)`) and an
`observation.environment_state` (`ENV_NAMES`, values `env_state(e, t)`) and a depth video camera (`DEPTH_CAMERA`,
uint16 millimetres `depth_pixels(e, t)`, lerobot's default `DepthEncoderConfig`). `loaded_episodes` reads any
dataset back through lerobot's loader for comparisons (`same_frames`), `digest` fingerprints its files."""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import numpy as np

LENGTHS = [6, 9, 4]
SUCCEEDED = [True, False, True]
VIDEO_CAMERA = "observation.images.cam"
IMAGE_CAMERA = "observation.images.wrist"
IMAGE_SHAPE = (24, 20, 3)
ENV_STATE = "observation.environment_state"
ENV_NAMES = ["block_x", "block_y", "block_angle", "goal_dist"]
Frame = dict[str, Any]
DEPTH_CAMERA = "observation.images.depth"
DEPTH_SHAPE = (32, 48, 1)


def depth_pixels(e: int, t: int) -> np.ndarray:
    """A depth frame (mm): a ramp from 300 mm, different per episode and frame, with a 0 (no return) corner."""
    h, w, _ = DEPTH_SHAPE
    y, x = np.mgrid[0:h, 0:w]
    d = (300 + 40 * x + 25 * y + 200 * e + 30 * t).astype(np.uint16)
    d[:2, :2] = 0
    return d[..., None]


def image_pixels(e: int, t: int) -> np.ndarray:
    """A frame of the image camera: a smooth gradient, different per episode and frame (checkable after JPEG)."""
    h, w, _ = IMAGE_SHAPE
    y, x = np.mgrid[0:h, 0:w]
    img = np.stack([x * 8 + t * 4, y * 6 + e * 30, np.full_like(x, 40 + 10 * t)], axis=-1)  # smooth, below 256
    return img.astype(np.uint8)


def env_state(e: int, t: int) -> np.ndarray:
    return np.array([0.25 * t, -0.5 * e, 0.125 * (t + e), 1.0 / (t + 1)], dtype=np.float32)


def write_lerobot_dataset(
    root: Path,
    with_success: bool,
    *,
    image_camera: bool = False,
    environment_state: bool = False,
    depth_camera: bool = False,
) -> None:
    from lerobot.configs.video import RGBEncoderConfig
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    features: dict[str, dict[str, object]] = {
        "observation.images.cam": {"dtype": "video", "shape": (32, 32, 3), "names": ["height", "width", "channels"]},
        "observation.state": {"dtype": "float32", "shape": (3,), "names": ["x", "y", "z"]},
        "action": {"dtype": "float32", "shape": (2,), "names": ["vx", "vy"]},
    }
    if image_camera:
        features[IMAGE_CAMERA] = {"dtype": "image", "shape": IMAGE_SHAPE, "names": ["height", "width", "channels"]}
    if environment_state:
        features[ENV_STATE] = {"dtype": "float32", "shape": (len(ENV_NAMES),), "names": ENV_NAMES}
    if depth_camera:
        features[DEPTH_CAMERA] = {
            "dtype": "video",
            "shape": DEPTH_SHAPE,
            "names": ["height", "width", "channels"],
            "info": {"is_depth_map": True},
        }
    if with_success:
        features["next.success"] = {"dtype": "bool", "shape": (1,), "names": None}
    ds = LeRobotDataset.create(
        "test/lerobot",
        fps=10,
        features=features,
        root=root,
        robot_type="lerobot_bot",
        use_videos=True,
        rgb_encoder=RGBEncoderConfig(vcodec="h264"),
        video_backend="pyav",
    )
    try:
        for e, (n, ok) in enumerate(zip(LENGTHS, SUCCEEDED, strict=True)):
            for t in range(n):
                frame: dict[str, object] = {
                    "observation.images.cam": np.full((32, 32, 3), 10 * t, dtype=np.uint8),
                    "observation.state": np.array([t, e, 0.5], dtype=np.float32),
                    "action": np.array([0.1 * t, -0.1 * t], dtype=np.float32),
                    "task": "push the block",
                }
                if image_camera:
                    frame[IMAGE_CAMERA] = image_pixels(e, t)
                if environment_state:
                    frame[ENV_STATE] = env_state(e, t)
                if depth_camera:
                    frame[DEPTH_CAMERA] = depth_pixels(e, t)
                if with_success:
                    frame["next.success"] = np.array([ok and t == n - 1])
                ds.add_frame(frame)
            ds.save_episode()
    finally:
        ds.finalize()


def digest(root: Path) -> dict[str, str]:
    """Every file under `root` -> its sha256 (a source must be byte-unchanged by an edit)."""
    return {
        str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest() for p in root.rglob("*") if p.is_file()
    }


def loaded_episodes(root: Path) -> list[list[Frame]]:
    """Every frame lerobot loads, grouped by episode: values (state, action, pixels, task, success) and indices."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/check", root=root, video_backend="pyav")
    out: list[list[Frame]] = [[] for _ in range(ds.meta.total_episodes)]
    for i in range(len(ds)):
        item = ds[i]
        assert int(item["index"]) == i
        e, t = int(item["episode_index"]), int(item["frame_index"])
        assert len(out[e]) == t and abs(float(item["timestamp"]) - t / ds.fps) < 1e-6
        out[e].append(
            {
                "state": item["observation.state"].numpy().tolist(),
                "action": item["action"].numpy().tolist(),
                "cam": item[VIDEO_CAMERA].numpy() if VIDEO_CAMERA in item else None,
                "wrist": item[IMAGE_CAMERA].numpy() if IMAGE_CAMERA in item else None,
                "task": item["task"],
                "success": bool(item["next.success"]) if "next.success" in item else None,
                "env": item["observation.environment_state"].numpy().tolist()
                if "observation.environment_state" in item
                else None,
            }
        )
    return out


def same_frames(got: list[Frame], want: list[Frame]) -> None:
    """Two episodes as `loaded_episodes` gives them hold the same frames (pixels equal, not just close)."""
    assert len(got) == len(want)
    for g, w in zip(got, want, strict=True):
        pictures = ("cam", "wrist")
        assert {k: v for k, v in g.items() if k not in pictures} == {k: v for k, v in w.items() if k not in pictures}
        for key in pictures:  # video packets and image bytes copied: the decoded pixels are the source's
            assert (g[key] is None) == (w[key] is None), key
            assert g[key] is None or np.array_equal(g[key], w[key]), key
