"""A small dataset written by lerobot 0.6.1 itself (no openral columns): three episodes, one camera."""

from __future__ import annotations

from pathlib import Path

import numpy as np

LENGTHS = [6, 9, 4]
SUCCEEDED = [True, False, True]


def write_lerobot_dataset(
    root: Path, with_success: bool, *, image_camera: bool = False, environment_state: bool = False
) -> None:
    """`image_camera`: also a `dtype: image` camera `observation.images.still` (PNG frames in the data parquet);
    `environment_state`: also `observation.environment_state` (float32 [4]: episode, frame, a ramp, a constant)."""
    from lerobot.configs.video import RGBEncoderConfig
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    features: dict[str, dict[str, object]] = {
        "observation.images.cam": {"dtype": "video", "shape": (32, 32, 3), "names": ["height", "width", "channels"]},
        "observation.state": {"dtype": "float32", "shape": (3,), "names": ["x", "y", "z"]},
        "action": {"dtype": "float32", "shape": (2,), "names": ["vx", "vy"]},
    }
    if with_success:
        features["next.success"] = {"dtype": "bool", "shape": (1,), "names": None}
    if environment_state:
        features["observation.environment_state"] = {"dtype": "float32", "shape": (4,), "names": None}
    if image_camera:
        features["observation.images.still"] = {
            "dtype": "image",
            "shape": (16, 16, 3),
            "names": ["height", "width", "channels"],
        }
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
                if environment_state:
                    frame["observation.environment_state"] = np.array([e, t, 0.25 * t, -1.0], dtype=np.float32)
                if image_camera:
                    frame["observation.images.still"] = np.full((16, 16, 3), 20 * t + e, dtype=np.uint8)
                if with_success:
                    frame["next.success"] = np.array([ok and t == n - 1])
                ds.add_frame(frame)
            ds.save_episode()
    finally:
        ds.finalize()
