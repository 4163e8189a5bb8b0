"""Datasets written by older lerobot releases' own writers, in the layouts people still hold.

`scripts/setup.sh` installs each release's code (no dependencies) into `.old-lerobot/<version>`; `write_old` runs
`old_lerobot_writer.py` with that folder first on PYTHONPATH, on this environment's torch/datasets/PyAV. So the
files come from lerobot's code of that release, not from ours: 0.3.3 writes LeRobot v2.1 (per-episode parquet
and mp4, jsonl meta, `episodes_stats.jsonl`), 0.4.4 the early v3.0 layout (`tasks.parquet` with the task text in
the unnamed pandas index, `__index_level_0__`). The frames are `lerobot_written`'s (`LENGTHS`, its camera and
state/action) with the tasks `TASKS` alternating per episode, so `loaded_episodes` output compares with them.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

from tests.support.old_lerobot_writer import TASKS

REPO = Path(__file__).resolve().parents[2]
RELEASES = {"0.3.3": "v2.1", "0.4.4": "v3.0"}  # release -> the codebase_version it writes

__all__ = ["RELEASES", "TASKS", "release_dir", "write_old"]


def release_dir(release: str) -> Path:
    """Where `scripts/setup.sh` put the release's code; a missing one is a setup error, never a skip."""
    folder = REPO / ".old-lerobot" / release
    if not (folder / ".installed").is_file():
        raise RuntimeError(f"{folder}: lerobot {release} is not installed; run `bash scripts/setup.sh`")
    return folder


def write_old(release: str, root: Path, *, lengths: Sequence[int] | None = None, image: bool = False) -> Path:
    """Write a dataset at `root` with lerobot `release`'s own writer (see the module docstring)."""
    spec: dict[str, object] = {"image": image}
    if lengths is not None:
        spec["lengths"] = list(lengths)
    env = dict(os.environ, HF_HUB_OFFLINE="1", PYTHONPATH=os.pathsep.join([str(release_dir(release)), str(REPO)]))
    script = Path(__file__).with_name("old_lerobot_writer.py")  # -P: its folder (holding lerobot.py) not on sys.path
    done = subprocess.run(
        [sys.executable, "-P", str(script), str(root), json.dumps(spec)],
        check=False,
        env=env,
        capture_output=True,
        text=True,
    )
    if done.returncode != 0:
        raise RuntimeError(f"lerobot {release} writer failed:\n{done.stderr[-3000:]}")
    return root
