"""The `capture` table of `stats`: how a real-time recording (`record --hal`) kept up, per episode and camera.

Read from each episode's `openral.episode_info` (meta/episodes): the loop's `hal` report (`overruns`, the
camera's `max_age`: the oldest sample a frame recorded, seconds since it arrived) and the writer's `capture`
block (`spilled`: frames the encoder was too slow for, written to the staging area and encoded behind;
`encoder_lag_s`: the longest a frame waited between being handed over and being encoded). Episodes without a
`capture` block (any other recording, a foreign dataset) add no rows; a value that is not a number is NULL.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from typing import Any

from openral_data.metrics.sources import DatasetSource

INFO = "openral.episode_info"
COLUMNS = ["dataset", "episode_index", "camera", "overruns", "spilled", "worst_frame_age_s", "encoder_lag_s"]


def capture_rows(datasets: Sequence[DatasetSource]) -> list[list[Any]]:
    """One row per episode and camera that records a `capture` block, in dataset and episode order."""
    rows: list[list[Any]] = []
    for ds in datasets:
        if INFO not in ds.episode_columns:
            continue
        table = ds.read_episodes(["episode_index", INFO]).to_pydict()
        for episode, text in sorted(zip(table["episode_index"], table[INFO], strict=True), key=lambda r: r[0]):
            rows += _episode_rows(ds.label, episode, text)
    return rows


def _episode_rows(dataset: str, episode: int, text: object) -> list[list[Any]]:
    try:
        info = json.loads(text) if isinstance(text, str) else None
    except ValueError:
        return []
    if not isinstance(info, dict) or not isinstance(capture := info.get("capture"), dict):
        return []
    hal = info.get("hal")
    overruns = _number(_get(hal, "overruns"))
    ages = _get(hal, "max_age")
    return [
        [
            dataset,
            episode,
            str(camera),
            overruns,
            _number(_get(lag, "spilled")),
            _number(_get(ages, camera)),
            _number(_get(lag, "encoder_lag_s")),
        ]
        for camera, lag in sorted(capture.items())
    ]


def _get(block: object, key: str) -> object:
    return block.get(key) if isinstance(block, dict) else None


def _number(value: object) -> float | int | None:
    return value if isinstance(value, int | float) and not isinstance(value, bool) else None
