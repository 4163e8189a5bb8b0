"""A replay results folder with known numbers, written through the results layout module."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from openral_data.formats import results as layout
from tests.support.metrics import data_file, episodes_file


def make_results(dataset: Path, out: Path, noise: float = 0.05) -> tuple[Path, dict[str, np.ndarray]]:
    """A replay of `dataset` whose actions differ from the recorded ones by seeded noise, through write_results."""
    data = pq.read_table(data_file(dataset))
    eps = pq.read_table(episodes_file(dataset))
    actions = np.asarray(data.column("action").combine_chunks().flatten()).reshape(data.num_rows, -1)
    rng = np.random.default_rng(0)
    replayed = actions + rng.normal(0, noise, actions.shape).astype(np.float32)
    err = np.linalg.norm(replayed - actions, axis=1).astype(np.float64)
    div = np.cumsum(err * 0.1)  # grows along the data; restarted per episode below
    ep_index = np.asarray(data.column("episode_index").to_numpy())
    frame_index = np.asarray(data.column("frame_index").to_numpy())
    for e in np.unique(ep_index):
        rows = ep_index == e
        div[rows] = np.cumsum(err[rows] * 0.1)
    recorded = eps.column("openral.success").to_pylist()
    replayed_ok = [bool(s) and i % 3 != 0 for i, s in enumerate(recorded)]
    episodes = pa.table(
        {
            "episode_index": eps.column("episode_index"),
            "steps": eps.column("length"),
            "success_recorded": recorded,
            "success_replayed": replayed_ok,
            "action_error_mean": [float(err[ep_index == e].mean()) for e in eps.column("episode_index").to_pylist()],
            "action_error_max": [float(err[ep_index == e].max()) for e in eps.column("episode_index").to_pylist()],
            "divergence_mean": [float(div[ep_index == e].mean()) for e in eps.column("episode_index").to_pylist()],
            "divergence_max": [float(div[ep_index == e].max()) for e in eps.column("episode_index").to_pylist()],
            "divergence_final": [float(div[ep_index == e][-1]) for e in eps.column("episode_index").to_pylist()],
        }
    )
    steps = pa.table({"episode_index": ep_index, "frame_index": frame_index, "action_error": err, "divergence": div})
    layout.write_results(out, {"kind": "replay", "dataset": str(dataset), "label": "replay-1"}, episodes, steps)
    return out, {"err": err, "div": div, "recorded": np.array(recorded), "replayed": np.array(replayed_ok)}
