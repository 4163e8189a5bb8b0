"""A dataset shaped like lerobot/pusht on the Hub, written by lerobot 0.6.1 itself: its camera key is
`observation.image` (not `observation.images.<name>`), its state/action names use lerobot's `{"motors": [...]}`
form, and it has `next.reward` and `next.success`."""

from __future__ import annotations

from pathlib import Path

import numpy as np

CAMERA_KEY = "observation.image"
LENGTHS = [5, 7]
NAMES = ["x", "y"]
TASK = "Push the T-shaped block onto the T-shaped target."


def grey(t: int) -> int:
    """The uniform grey level of frame t."""
    return 20 * t


def write_pusht_like(root: Path, *, camera_dtype: str = "video") -> None:
    """`camera_dtype="image"`: the camera is a `dtype: image` feature (PNG cells in the data parquet)."""
    from lerobot.configs.video import RGBEncoderConfig
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    features: dict[str, dict[str, object]] = {
        CAMERA_KEY: {"dtype": camera_dtype, "shape": (32, 32, 3), "names": ["height", "width", "channels"]},
        "observation.state": {"dtype": "float32", "shape": (2,), "names": {"motors": NAMES}},
        "action": {"dtype": "float32", "shape": (2,), "names": {"motors": NAMES}},
        "next.reward": {"dtype": "float32", "shape": (1,), "names": None},
        "next.success": {"dtype": "bool", "shape": (1,), "names": None},
    }
    ds = LeRobotDataset.create(
        "lerobot/pusht_like",
        fps=10,
        features=features,
        root=root,
        robot_type="2d pointer",
        use_videos=True,
        rgb_encoder=RGBEncoderConfig(vcodec="h264"),
        video_backend="pyav",
    )
    try:
        for e, n in enumerate(LENGTHS):
            for t in range(n):
                ds.add_frame(
                    {
                        CAMERA_KEY: np.full((32, 32, 3), grey(t), dtype=np.uint8),
                        "observation.state": np.array([t, e], dtype=np.float32),
                        "action": np.array([t + 0.5, -e], dtype=np.float32),
                        "next.reward": np.array([0.1 * t], dtype=np.float32),
                        "next.success": np.array([e == 0 and t == n - 1]),
                        "task": TASK,
                    }
                )
            ds.save_episode()
    finally:
        ds.finalize()
