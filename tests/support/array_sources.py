"""Helpers for the episodic array sources' tests (HDF5, zarr replay buffers, RLDS): damage a copy of a good source,
read a source through, check a refusal is one line naming the file, check lerobot loads a conversion as we do."""

from __future__ import annotations

import re
import shutil
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from openral_data.errors import OpenralError
from openral_data.formats.episodic import ArraySource
from openral_data.replay.recorded import RecordedDataset


def damaged(good: Path, bad: Path, damage: Callable[[Path], None]) -> Path:
    """A copy of the source folder `good` at `bad`, then `damage`d."""
    shutil.copytree(good, bad)
    damage(bad)
    return bad


def read_all(source: ArraySource | None) -> int:
    """Every row of every array of every episode read (the way convert reads them); the rows read."""
    assert source is not None
    rows = 0
    try:
        for episode in source.episodes():
            for spec in episode.specs():
                rows += len(episode.read(spec.key, 0, episode.length))
    finally:
        source.close()
    return rows


def assert_one_line(err: OpenralError, path: Path, pattern: str) -> None:
    """`err` is one line that starts with `path` and matches `pattern`."""
    text = str(err)
    assert "\n" not in text and text.startswith(str(path)) and re.search(pattern, text), text


def lerobot_matches_ours(root: Path, ours: RecordedDataset) -> None:
    """lerobot 0.6.1 loads every frame: numbers as stored, pixels equal to our own decode."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/check", root=root, video_backend="pyav")
    mine = {e: list(ours.frames(e)) for e in range(len(ours))}
    for i in range(len(ds)):
        item = ds[i]
        frame = mine[int(item["episode_index"])][int(item["frame_index"])]
        assert item["observation.state"].numpy().tolist() == frame.state.tolist()
        assert item["action"].numpy().tolist() == frame.action.tolist()
        for name, img in frame.images.items():
            loaded = (item[f"observation.images.{name}"].numpy() * 255).round().astype(np.uint8).transpose(1, 2, 0)
            assert np.array_equal(loaded, img), (i, name)


def converted_episodes(src: Path, out: Path, episodes: int, *args: str) -> list[pa.Table]:
    """`convert SRC OUT --codec h264 ARGS...` run (it must succeed); OUT's data rows of each of its `episodes`
    episodes, in index order."""
    from tests.support.inproc import run_inproc

    run = run_inproc("convert", str(src), str(out), "--codec", "h264", *args)
    assert run.returncode == 0, run.stderr
    table = pq.read_table(out / "data").sort_by("index")
    eps = np.array(table.column("episode_index").to_pylist())
    assert sorted(set(eps.tolist())) == list(range(episodes))
    return [table.filter(eps == e) for e in range(episodes)]
