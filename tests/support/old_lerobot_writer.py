"""Run by `old_lerobot.write_old` in a subprocess whose PYTHONPATH starts with an older lerobot release's code:
writes the dataset of `lerobot_written` (same frames, cameras and names; two tasks) with that release's own
`LeRobotDataset` writer, in the layout that release wrote. Usage: `python old_lerobot_writer.py ROOT SPEC_JSON`."""

from __future__ import annotations

import inspect
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from tests.support.lerobot_written import IMAGE_CAMERA, IMAGE_SHAPE, LENGTHS, VIDEO_CAMERA, image_pixels

TASKS = ["push the block", "lift the cube"]


def features(spec: dict[str, Any]) -> dict[str, dict[str, Any]]:
    out: dict[str, dict[str, Any]] = {
        VIDEO_CAMERA: {"dtype": "video", "shape": (32, 32, 3), "names": ["height", "width", "channels"]},
        "observation.state": {"dtype": "float32", "shape": (3,), "names": ["x", "y", "z"]},
        "action": {"dtype": "float32", "shape": (2,), "names": ["vx", "vy"]},
    }
    if spec.get("image"):
        out[IMAGE_CAMERA] = {"dtype": "image", "shape": IMAGE_SHAPE, "names": ["height", "width", "channels"]}
    return out


def main(root: Path, spec: dict[str, Any]) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset  # the older release's, first on sys.path

    ds: Any = LeRobotDataset.create("test/old", fps=10, root=root, features=features(spec), use_videos=True)
    task_in_frame = "task" not in inspect.signature(ds.add_frame).parameters  # lerobot >= 0.4 moved it
    for e, n in enumerate(spec.get("lengths", LENGTHS)):
        task = TASKS[e % len(TASKS)]
        for t in range(n):
            frame: dict[str, Any] = {
                VIDEO_CAMERA: np.full((32, 32, 3), 10 * t, dtype=np.uint8),
                "observation.state": np.array([t, e, 0.5], dtype=np.float32),
                "action": np.array([0.1 * t, -0.1 * t], dtype=np.float32),
            }
            if spec.get("image"):
                frame[IMAGE_CAMERA] = image_pixels(e, t)
            if task_in_frame:
                frame["task"] = task
                ds.add_frame(frame)
            else:
                ds.add_frame(frame, task=task)
        ds.save_episode()
    if hasattr(ds, "finalize"):
        ds.finalize()


if __name__ == "__main__":
    main(Path(sys.argv[1]), json.loads(sys.argv[2]))
