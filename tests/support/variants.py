"""Layout variants of LeRobot v3 that lerobot 0.6.1's loader reads, each made by altering a dataset lerobot's own
writer made (`lerobot_written.write_lerobot_dataset`) the way older lerobot versions or other tools wrote it:

- `old-tasks`: `meta/tasks.parquet` as lerobot < 0.5 wrote it, `pd.DataFrame({"task_index": ...}, index=tasks)
  .to_parquet(...)`: the task text in the unnamed pandas index (parquet column `__index_level_0__`), no `task`.
- `channel-names`: the video camera's `names` spelled `["height", "width", "channel"]` (lerobot's eval script).
- `video-info`: the video camera's `info` block moved to a legacy `video_info` block (`video_info-both`: a
  `video_info` block next to `info`).
- `no-stats`: no `meta/stats.json` and no `stats/...` columns in meta/episodes (lerobot: stats are optional).
- `some-stats`: the statistics of `action` missing from stats.json and from meta/episodes.
- `names-forms`: `observation.state`'s names as `{"motors": [...]}`, `action`'s names null.
- `channel-first`: the video camera's shape `[3, H, W]`, names `["channel", "height", "width"]`.
- `camera-names-null`: the video camera's names null.

`VARIANTS` maps each name to its alteration (of `write_lerobot_dataset(root, True, image_camera=True)`);
`legacy_depth` alters one written with `depth_camera=True`."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pyarrow.parquet as pq

from tests.support.lerobot_written import DEPTH_CAMERA, VIDEO_CAMERA

TASKS = "meta/tasks.parquet"
INFO = "meta/info.json"


def old_tasks(root: Path) -> None:
    """tasks.parquet as lerobot < 0.5 wrote it: the task texts as an unnamed pandas index."""
    import pandas as pd

    tasks = pd.read_parquet(root / TASKS)
    old = pd.DataFrame({"task_index": tasks["task_index"].to_list()}, index=list(tasks.index))
    old.to_parquet(root / TASKS)
    assert "__index_level_0__" in pq.read_schema(root / TASKS).names


def _edit_info(root: Path, change: Callable[[dict[str, Any]], None]) -> None:
    info = json.loads((root / INFO).read_text())
    change(info["features"])
    (root / INFO).write_text(json.dumps(info, indent=4))


def channel_names(root: Path) -> None:
    def change(features: dict[str, Any]) -> None:
        features[VIDEO_CAMERA]["names"] = ["height", "width", "channel"]

    _edit_info(root, change)


def video_info(root: Path) -> None:
    def change(features: dict[str, Any]) -> None:
        features[VIDEO_CAMERA]["video_info"] = features[VIDEO_CAMERA].pop("info")

    _edit_info(root, change)


def video_info_both(root: Path) -> None:
    def change(features: dict[str, Any]) -> None:
        feature = features[VIDEO_CAMERA]
        feature["video_info"] = {k: v for k, v in feature["info"].items() if k.startswith("video.")}

    _edit_info(root, change)


def _drop_stats(root: Path, keep: Callable[[str], bool]) -> None:
    for path in sorted((root / "meta/episodes").rglob("*.parquet")):
        table = pq.read_table(path)
        pq.write_table(table.select([c for c in table.column_names if not c.startswith("stats/") or keep(c)]), path)


def no_stats(root: Path) -> None:
    (root / "meta/stats.json").unlink()
    _drop_stats(root, lambda _: False)


def some_stats(root: Path) -> None:
    stats = json.loads((root / "meta/stats.json").read_text())
    del stats["action"]
    (root / "meta/stats.json").write_text(json.dumps(stats, indent=4))
    _drop_stats(root, lambda c: not c.startswith("stats/action/"))


def names_forms(root: Path) -> None:
    def change(features: dict[str, Any]) -> None:
        features["observation.state"]["names"] = {"motors": features["observation.state"]["names"]}
        features["action"]["names"] = None

    _edit_info(root, change)


def channel_first(root: Path) -> None:
    """The video camera's shape given channel first, `[3, H, W]` with names `["channel", "height", "width"]`."""

    def change(features: dict[str, Any]) -> None:
        h, w, c = features[VIDEO_CAMERA]["shape"]
        features[VIDEO_CAMERA].update(shape=[c, h, w], names=["channel", "height", "width"])

    _edit_info(root, change)


def camera_names_null(root: Path) -> None:
    def change(features: dict[str, Any]) -> None:
        features[VIDEO_CAMERA]["names"] = None

    _edit_info(root, change)


VARIANTS: dict[str, Callable[[Path], None]] = {
    "old-tasks": old_tasks,
    "channel-names": channel_names,
    "video-info": video_info,
    "video_info-both": video_info_both,
    "no-stats": no_stats,
    "some-stats": some_stats,
    "names-forms": names_forms,
    "channel-first": channel_first,
    "camera-names-null": camera_names_null,
}


def legacy_depth(root: Path) -> None:
    """The depth camera flagged the legacy way lerobot still reads: `video.is_depth_map` in a `video_info` block
    (for a dataset written with `depth_camera=True`)."""

    def change(features: dict[str, Any]) -> None:
        feature = features[DEPTH_CAMERA]
        info = feature.pop("info")
        del info["is_depth_map"]
        feature["video_info"] = {**info, "video.is_depth_map": True}

    _edit_info(root, change)
