"""A LeRobot dataset of any version the read-only commands take (v3.0, and v2.0/v2.1 read in place), opened in
one place: `open_lerobot` reads info.json once and picks the reader by its ``codebase_version``.

The v3 readers (`lerobot_v3.reader`) refuse a v2.x dataset in one line pointing at `openral-data upgrade`, so
every writing command stays v3-only (the CLI gives them a temporary upgrade instead: `cli/legacy.py`); `info`,
`doctor`, `stats`, `view`, `tasks list` and `convert` (to MCAP) open datasets here and take v2.x as it is
(`lerobot_v2`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pyarrow as pa

from openral_data.formats import lerobot_v2
from openral_data.formats.lerobot_v3 import layout, reader
from openral_data.formats.lerobot_v3.success import count_successes, episode_successes


@dataclass(frozen=True)
class LeRobotDataset:
    """A dataset's root, its info.json (v2.x: with v3 path templates, `lerobot_v2.as_v3_info`) and its version
    when it is a v2.x one (`legacy`)."""

    root: Path
    info: dict[str, Any]
    legacy: str | None = None  # "v2.0" / "v2.1", None for v3

    def episodes(self) -> pa.Table:
        """Every row of the episodes table (v3: meta/episodes/ as written, incl. an unfinished commit's rows)."""
        if self.legacy:
            return lerobot_v2.read_episodes(self.root, self.info)
        return reader.read_episodes(self.root)

    def committed_episodes(self) -> pa.Table:
        """The episodes info.json's totals count (`reader.committed_episodes`)."""
        if self.legacy:
            return lerobot_v2.read_episodes(self.root, self.info)
        return reader.committed_episodes(self.root, self.info, reader.read_episodes(self.root))

    def tasks(self) -> list[str]:
        """The task texts in task_index order."""
        if self.legacy:
            return lerobot_v2.read_tasks(self.root, self.info)
        return reader.dataset_tasks(self.root, self.info)

    def data_files(self) -> list[Path]:
        """The frame tables (v2.x: each episode's parquet, in episode order; v3: data/*/*.parquet on disk)."""
        if self.legacy:
            return lerobot_v2.data_files(self.root, self.info, self.episodes())
        return layout.data_files(self.root)


def open_lerobot(root: Path) -> LeRobotDataset:
    """The dataset at `root`, v3 or v2.x; anything else wrong with its info.json is one line."""
    raw = lerobot_v2.read_raw_info(root)
    version = lerobot_v2.version(raw)
    if version is None:
        return LeRobotDataset(root, reader.read_info(root))
    return LeRobotDataset(root, lerobot_v2.as_v3_info(root, raw), version)


def summarize(root: Path) -> reader.DatasetSummary:
    """`reader.summarize` for a dataset of any version."""
    ds = open_lerobot(root)
    if not ds.legacy:
        return reader.summarize(root)
    episodes = ds.committed_episodes()
    successes, known = count_successes(episode_successes(root, episodes))
    return reader.DatasetSummary(
        root=root,
        fps=int(ds.info["fps"]),
        episodes=episodes.num_rows,
        frames=sum(episodes.column("length").to_pylist()),
        tasks=ds.tasks(),
        cameras=[k for k, f in ds.info["features"].items() if f.get("dtype") in ("video", "image")],
        successes=successes if known else None,
        robot_type=ds.info.get("robot_type"),
        success_known=known,
        codebase_version=ds.legacy,
    )
