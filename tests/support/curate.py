"""Helpers of the curate tests (features rename/add, merge --rename, split --spec): a camera's mp4 packets, the
items lerobot 0.6.1 loads for chosen keys, and a refusal's one line."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import av
import numpy as np

from tests.support.inproc import run_inproc


def packets(root: Path, key: str) -> list[bytes]:
    """Every video packet of camera `key`, file by file, in order (copied streams keep them byte for byte)."""
    out: list[bytes] = []
    for f in sorted((root / "videos" / key).glob("*/*.mp4")):
        with av.open(str(f)) as c:
            out += [bytes(p) for p in c.demux(c.streams.video[0]) if p.size]
    return out


def stream(root: Path, key: str) -> set[tuple[str, int, int, str]]:
    """(codec, width, height, pix_fmt) of every mp4 file of camera `key`."""
    found = set()
    for f in sorted((root / "videos" / key).glob("*/*.mp4")):
        with av.open(str(f)) as c:
            s = c.streams.video[0].codec_context
            found.add((s.name, s.width, s.height, str(s.pix_fmt)))
    return found


def lerobot_items(root: Path, keys: list[str]) -> list[dict[str, Any]]:
    """Every item lerobot loads from `root`, the values of `keys` as numpy arrays."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/check", root=root, video_backend="pyav")
    return [{k: np.asarray(ds[i][k].numpy()) for k in keys} for i in range(len(ds))]


def refused(*args: str) -> str:
    """Run `openral-data ARGS`, expect a one-line refusal (exit 2) and return it."""
    res = run_inproc(*args)
    assert res.returncode == 2, (res.stdout, res.stderr)
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), res.stderr
    return lines[0]
