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

import io
import json
from pathlib import Path
from typing import Any

import av
import numpy as np
import pyarrow.parquet as pq
from PIL import Image

from tests.support.lerobot_written import IMAGE_CAMERA, VIDEO_CAMERA, Frame, loaded_episodes, write_lerobot_dataset
from tests.support.old_lerobot import write_old
from tests.support.upgrade_cases import reference

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


def chw(pixels: np.ndarray) -> np.ndarray:
    """HWC uint8 as lerobot's loader hands a picture out: CHW float32 in [0, 1]."""
    return (pixels.astype(np.float32) / 255.0).transpose(2, 0, 1)


def source_frames(kind: str, root: Path) -> list[list[Frame]]:
    """The frames of `root` as `loaded_episodes` gives them: by lerobot 0.6.1's loader for v3, and for v2.x (which
    that loader refuses) from the per-episode parquet, mp4 and PNG bytes directly."""
    if kind not in LEGACY:
        return loaded_episodes(root)
    tasks = {
        row["task_index"]: row["task"] for row in map(json.loads, (root / "meta/tasks.jsonl").read_text().splitlines())
    }
    out: list[list[Frame]] = []
    for data in sorted((root / "data").glob("chunk-*/episode_*.parquet")):
        rows: list[dict[str, Any]] = pq.read_table(data).to_pylist()
        video = root / "videos" / data.parent.name / VIDEO_CAMERA / data.with_suffix(".mp4").name
        with av.open(str(video)) as container:
            pictures = [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]
        assert len(pictures) == len(rows)
        out.append(
            [
                {
                    "state": row["observation.state"],
                    "action": row["action"],
                    "cam": chw(picture),
                    "wrist": chw(np.asarray(Image.open(io.BytesIO(row[IMAGE_CAMERA]["bytes"])).convert("RGB"))),
                    "task": tasks[row["task_index"]],
                    "success": None,
                    "env": None,
                }
                for row, picture in zip(rows, pictures, strict=True)
            ]
        )
    return out
