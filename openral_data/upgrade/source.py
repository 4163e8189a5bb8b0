"""The v2.1 dataset lerobot's converter reads: OLD's files, fixed up in a scratch folder, OLD left untouched.

lerobot's converter globs `data/*/*.parquet` and `videos/*/KEY/*.mp4` and trusts `meta/` as it is; what it gets
wrong is fixed here, before it runs, in a copy of `meta/` (OLD is only read):

* `episodes_stats.jsonl` is complete: a v2.0 dataset has none, a v2.1 one may lack its cameras (computed,
  `episode_stats`); camera statistics stored flat (`[r, g, b]`) take lerobot's (3, 1, 1) shape;
* `info.json` has what the converter indexes (`total_chunks`, `total_videos`, `video_path`) and says v2.1; a
  camera with `names: null` gets lerobot's `["height", "width", "channels"]` (lerobot issue #3786; the loader's
  policy features index `names[2]`);
* an episode's `length` is its data file's row count, and info.json's totals are counted (either can be stale);
  episodes are numbered 0..n-1 in OLD's order (a subset of a larger dataset keeps its numbers in OLD);
* `data/` and `videos/` hold exactly the listed episodes' files, under lerobot's v2.1 names, as symlinks to
  OLD's (stray files in OLD are not picked up by the glob; a file whose real path holds a `'`, which the
  ffconcat list lerobot writes cannot quote, is copied instead).
"""

from __future__ import annotations

import copy
import json
import shutil
from pathlib import Path
from typing import Any

from openral_data.upgrade.episode_stats import CAMERAS
from openral_data.upgrade.legacy import (
    DATA_TEMPLATE,
    EPISODES,
    EPISODES_STATS,
    INFO,
    TASKS,
    VIDEO_TEMPLATE,
    Legacy,
)

HWC = ["height", "width", "channels"]
CHW = ["channels", "height", "width"]


def write_source(
    legacy: Legacy, data: list[Path], stats: dict[int, dict[str, Any]], lengths: list[int], at: Path
) -> None:
    """The fixed-up v2.1 dataset lerobot's converter reads, at `at` (a new folder): episodes numbered 0..n-1,
    each episode's data file `data[e]` (OLD's, or its rewrite by `columns.fixed_data`)."""
    (at / "meta").mkdir(parents=True)
    _write_json(at / INFO, fixed_info(legacy, lengths))
    episodes = [
        {**ep, "episode_index": e, "length": n} for e, (ep, n) in enumerate(zip(legacy.episodes, lengths, strict=True))
    ]
    _write_lines(at / EPISODES, episodes)
    _write_lines(at / TASKS, legacy.tasks)
    cameras = set(legacy.keys_of(*CAMERAS))
    rows = [{"episode_index": e, "stats": _shaped(stats[e], cameras)} for e in range(len(legacy.episodes))]
    _write_lines(at / EPISODES_STATS, rows)
    for e, path in enumerate(data):
        values = {"episode_chunk": 0, "episode_index": e}  # one chunk: lerobot's sorted globs keep episode order
        _link(path, at / DATA_TEMPLATE.format(**values))
        for key, videos in legacy.videos.items():
            _link(videos[e], at / VIDEO_TEMPLATE.format(**values, video_key=key))


def fixed_info(legacy: Legacy, lengths: list[int]) -> dict[str, Any]:
    """info.json as lerobot's converter needs it (see the module docstring), its totals counted."""
    info: dict[str, Any] = copy.deepcopy(legacy.info)
    info["codebase_version"] = "v2.1"
    info["total_episodes"] = len(lengths)
    info["total_frames"] = sum(lengths)
    info["total_tasks"] = len(legacy.tasks)
    info.setdefault("total_chunks", 0)
    info.setdefault("total_videos", 0)
    info["data_path"] = DATA_TEMPLATE  # where `write_source` links the files (OLD's own template may differ)
    if "video_path" not in info or legacy.videos:
        info["video_path"] = VIDEO_TEMPLATE if legacy.videos else None
    for ft in info["features"].values():
        if ft["dtype"] in CAMERAS and ft.get("names") is None:
            ft["names"] = camera_names(ft["shape"])
    return info


def camera_names(shape: list[int]) -> list[str] | None:
    """lerobot's axis names for a camera of `shape`: channels last unless only the first axis looks like them."""
    if len(shape) != 3:
        return None
    channels = (1, 3, 4)
    return CHW if shape[0] in channels and shape[2] not in channels else HWC


def _shaped(stats: dict[str, Any], cameras: set[str]) -> dict[str, Any]:
    """A camera's statistics stored flat (one value per channel) in lerobot's (C, 1, 1) shape."""
    out = dict(stats)
    for key in cameras & out.keys():
        out[key] = {name: v if name == "count" or not _flat(v) else [[[x]] for x in v] for name, v in out[key].items()}
    return out


def _flat(value: object) -> bool:
    return isinstance(value, list) and bool(value) and all(isinstance(x, int | float) for x in value)


def _link(target: Path, at: Path) -> None:
    at.parent.mkdir(parents=True, exist_ok=True)
    real = target.resolve()
    if "'" in str(real):
        shutil.copyfile(real, at)
    else:
        at.symlink_to(real)


def _write_json(path: Path, doc: Any) -> None:
    path.write_text(json.dumps(doc, indent=4, ensure_ascii=False) + "\n", encoding="utf-8")


def _write_lines(path: Path, rows: list[dict[str, Any]]) -> None:
    path.write_text("".join(json.dumps(r, ensure_ascii=False) + "\n" for r in rows), encoding="utf-8")
