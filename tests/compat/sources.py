"""The datasets the compatibility matrix runs on, each written by code that is not ours, and the frames each
holds read without our code (pyarrow, PyAV, PIL), so a command's output is compared with the source itself.

* `v3.0`: lerobot 0.6.1's writer (`lerobot_written`), one video and one image camera.
* `v3.0-early`: lerobot 0.4.4's writer (`old_lerobot`): tasks.parquet keeps the task in the pandas index.
* `v2.1`: lerobot 0.3.3's writer: per-episode parquet and mp4, jsonl meta, `episodes_stats.jsonl`.
* `v3.0-converted`: that v2.1 dataset converted by lerobot 0.6.1's own `convert_dataset_v21_to_v30` (what
  many Hub datasets are: per-feature `fps` keys, stats without quantiles).
* `v2.0`: that v2.1 dataset as lerobot's v2.0 layout had it: no `episodes_stats.jsonl`, one `meta/stats.json`
  (lerobot 0.6.1's `aggregate_stats` of the per-episode stats), `codebase_version` "v2.0".
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from tests.support.lerobot_written import Frame, loaded_episodes, write_lerobot_dataset
from tests.support.old_lerobot import write_old
from tests.support.upgrade_cases import old_frames, reference

KINDS = ["v3.0", "v3.0-early", "v3.0-converted", "v2.1", "v2.0"]
LEGACY = {"v2.1", "v2.0"}


def build(kind: str, root: Path) -> Path:
    if kind == "v3.0":
        write_lerobot_dataset(root, with_success=False, image_camera=True)
    elif kind == "v3.0-early":
        write_old("0.4.4", root, image=True)
    elif kind == "v3.0-converted":
        reference(write_old("0.3.3", root.parent / "v2.1", image=True), root.parent).rename(root)
    else:
        write_old("0.3.3", root, image=True)
        if kind == "v2.0":
            to_v20(root)
    return root


def to_v20(root: Path) -> None:
    """lerobot's v2.0 layout from its v2.1 one: one dataset-wide stats.json instead of per-episode stats."""
    from lerobot.datasets.compute_stats import aggregate_stats

    lines = (root / "meta/episodes_stats.jsonl").read_text().splitlines()
    per_episode = [
        {k: {s: np.asarray(v) for s, v in st.items()} for k, st in json.loads(line)["stats"].items()} for line in lines
    ]
    stats = aggregate_stats(per_episode)
    (root / "meta/stats.json").write_text(
        json.dumps({k: {s: np.asarray(v).tolist() for s, v in st.items()} for k, st in stats.items()}, indent=4)
    )
    (root / "meta/episodes_stats.jsonl").unlink()
    info = json.loads((root / "meta/info.json").read_text())
    info["codebase_version"] = "v2.0"
    (root / "meta/info.json").write_text(json.dumps(info, indent=4))


def source_frames(kind: str, root: Path) -> list[list[Frame]]:
    """The frames of `root` as `loaded_episodes` gives them: by lerobot 0.6.1's loader for v3, and for v2.x (which
    that loader refuses) from the per-episode parquet, mp4 and PNG bytes directly (`upgrade_cases.old_frames`)."""
    return old_frames(root) if kind in LEGACY else loaded_episodes(root)
