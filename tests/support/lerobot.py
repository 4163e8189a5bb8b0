"""Open a dataset with lerobot 0.6.1's own loader and check every frame against what the mock produced.

Usable in-process (`verify_mock_dataset`) and as a script (`python -m tests.support.lerobot ROOT [BACKEND]`, run from
the repo root; without BACKEND lerobot picks its default), so a test can read what a fresh interpreter prints on a load.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

COLOUR_TOL = 4.0  # codec tolerance, in 0..255 levels, on a frame's mean colour


def verify_mock_dataset(root: Path, backend: str | None = "pyav", uncounted_rows_ok: bool = False) -> dict[str, Any]:
    """Assert frame-exact alignment of a mock-scene dataset; return what was seen. `backend=None`: lerobot's default.

    `uncounted_rows_ok`: meta/episodes may hold rows beyond info.json's total (a writer killed between its
    last two renames); only the counted episodes are checked.
    """
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/check", root=root, video_backend=backend)
    if backend is not None:
        assert ds._video_backend == backend, ds._video_backend
    episodes = ds.meta.episodes
    lengths = [int(x) for x in episodes["length"]]
    counted = ds.meta.total_episodes
    assert uncounted_rows_ok or len(lengths) == counted, (len(lengths), counted)
    lengths = lengths[:counted]
    assert len(ds) == sum(lengths) == ds.meta.total_frames
    worst = 0.0
    for i in range(len(ds)):
        item = ds[i]
        e, t = int(item["episode_index"]), int(item["frame_index"])
        state = item["observation.state"].numpy()
        assert state[0] == t and state[1] == e and not state[2:].any(), (i, state)
        assert int(item["index"]) == i
        assert abs(float(item["timestamp"]) - t / ds.fps) < 1e-6
        assert item["task"] == "pick up the mock cube", item["task"]
        for key in ds.meta.video_keys:
            colour = item[key].numpy().mean(axis=(1, 2)) * 255.0
            err = float(np.abs(colour - np.array([t % 256, e % 256, 128])).max())
            worst = max(worst, err)
            assert err <= COLOUR_TOL, (key, i, e, t, colour)
    boundaries = [
        (int(a), int(b)) for a, b in zip(episodes["dataset_from_index"], episodes["dataset_to_index"], strict=True)
    ][:counted]
    return {
        "len": len(ds),
        "lengths": lengths,
        "boundaries": boundaries,
        "worst_colour_error": worst,
        "video_backend": ds._video_backend,
        "video_keys": list(ds.meta.video_keys),
    }


if __name__ == "__main__":
    result = verify_mock_dataset(Path(sys.argv[1]), sys.argv[2] if len(sys.argv) > 2 else None)
    print(json.dumps(result))
