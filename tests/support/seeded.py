"""lerobot 0.6.1 loads a dataset of the *seeded* mock scene frame-exactly, whatever edits re-indexed it.

With `seeded: true` the mock's episode number is its seed, so every frame says where it came from: state
`[t, seed, 0, …]`, colour (t, seed, 128). After a delete/split/merge or a parallel recording, output episode k
must hold exactly the frames of the episode whose `openral.seed` its metadata names, in order.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq

from tests.support.lerobot import COLOUR_TOL


def episode_seeds(root: Path) -> list[int]:
    files = sorted((root / "meta" / "episodes").glob("*/*.parquet"))
    seeds: list[int] = []
    for f in files:
        seeds += [int(s) for s in pq.read_table(f, columns=["openral.seed"]).column("openral.seed").to_pylist()]
    return seeds


def verify_seeded_dataset(root: Path, backend: str | None = "pyav") -> dict[str, Any]:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/check", root=root, video_backend=backend)
    seeds = episode_seeds(root)
    lengths = [int(x) for x in ds.meta.episodes["length"]]
    assert len(ds) == sum(lengths) == ds.meta.total_frames
    assert ds.meta.total_episodes == len(seeds) == len(lengths)
    expected_t = 0
    expected_e = 0
    for i in range(len(ds)):
        item = ds[i]
        e, t = int(item["episode_index"]), int(item["frame_index"])
        assert (e, t) == (expected_e, expected_t), (i, e, t)
        expected_t += 1
        if expected_t == lengths[e]:
            expected_e, expected_t = expected_e + 1, 0
        state = item["observation.state"].numpy()
        assert state[0] == t and state[1] == seeds[e] and not state[2:].any(), (i, state, seeds[e])
        assert int(item["index"]) == i
        assert abs(float(item["timestamp"]) - t / ds.fps) < 1e-6
        for key in ds.meta.video_keys:
            colour = item[key].numpy().mean(axis=(1, 2)) * 255.0
            err = float(np.abs(colour - np.array([t % 256, seeds[e] % 256, 128])).max())
            assert err <= COLOUR_TOL, (key, i, e, t, colour)
    return {"lengths": lengths, "seeds": seeds, "len": len(ds)}
