"""Run by .venv's Python (lerobot 0.6.1), not by pytest, for tests running in another environment (.venv-maniskill
has no lerobot; a folder of its own: a script's folder comes first on sys.path, and tests/support/lerobot.py would
shadow lerobot there): load a LeRobot v3 dataset with lerobot's own `LeRobotDataset` and save every frame it returns as
one .npz: `state`, `action`, `success`, `episode`, `frame`, `task`, `images|<feature>` (uint8 HWC, as decoded) and
`depth|<feature>` (a depth camera's (H, W) maps in its `depth_unit`, as lerobot dequantizes them).

    .venv/bin/python tests/support/readers/lerobot_frames.py ROOT OUT.npz
"""

import sys

import numpy as np
from lerobot.datasets.lerobot_dataset import LeRobotDataset  # type: ignore[import-not-found,unused-ignore]


def main(root: str, target: str) -> None:
    ds = LeRobotDataset("local/check", root=root, video_backend="pyav")
    frames = [ds[i] for i in range(len(ds))]
    arrays = {
        "state": np.stack([f["observation.state"].numpy() for f in frames]),
        "action": np.stack([f["action"].numpy() for f in frames]),
        "success": np.array([bool(f["next.success"]) for f in frames]),
        "episode": np.array([int(f["episode_index"]) for f in frames]),
        "frame": np.array([int(f["frame_index"]) for f in frames]),
        "task": np.array([f["task"] for f in frames]),
        "fps": np.array(ds.fps),
    }
    for key in ds.meta.video_keys:  # CHW float in [0, 1] -> HWC uint8
        if ds.meta.features[key].get("info", {}).get("is_depth_map"):
            arrays[f"depth|{key}"] = np.stack([f[key].numpy().reshape(f[key].shape[-2:]) for f in frames])
            continue
        arrays[f"images|{key}"] = np.stack(
            [(f[key].numpy().transpose(1, 2, 0) * 255).round().astype(np.uint8) for f in frames]
        )
    np.savez(target, **arrays)  # type: ignore[arg-type]


if __name__ == "__main__":
    main(*sys.argv[1:3])
