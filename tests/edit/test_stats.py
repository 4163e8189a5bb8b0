"""`stats recompute`: a dataset whose stats.json and episodes' statistics were tampered with comes back with the
statistics a recording of the same data has (numeric features: exactly our writer's; cameras: the writer's
histogram method over the decoded pixels), healthy, loading the same frames; the source is unchanged; `stats
DATASET` keeps printing the report."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from openral_data.doctor import check
from openral_data.formats.lerobot_v3.stats import ImageStatsAccumulator, numeric_stats, to_jsonable
from tests.support.cli import run_cli
from tests.support.lerobot_written import (
    ENV_STATE,
    IMAGE_CAMERA,
    LENGTHS,
    VIDEO_CAMERA,
    digest,
    image_pixels,
    loaded_episodes,
    same_frames,
    write_lerobot_dataset,
)

EPISODES = "meta/episodes/chunk-000/file-000.parquet"


def _tamper(root: Path) -> None:
    """Every statistic in stats.json and meta/episodes replaced by zeros (counts by 1)."""
    stats = json.loads((root / "meta/stats.json").read_text())
    zero = {k: {s: np.zeros_like(np.asarray(v)).tolist() for s, v in f.items()} for k, f in stats.items()}
    (root / "meta/stats.json").write_text(json.dumps(zero))
    table = pq.read_table(root / EPISODES)
    for i, name in enumerate(table.column_names):
        if name.startswith("stats/"):
            values = [np.zeros_like(np.asarray(v)).tolist() for v in table.column(name).to_pylist()]
            table = table.set_column(i, name, pa.array(values, type=table.schema.field(name).type))
    pq.write_table(table, root / EPISODES)


def _episode_stats(root: Path, key: str) -> list[dict[str, Any]]:
    rows = pq.read_table(root / "meta/episodes").to_pylist()
    return [
        {s: r[f"stats/{key}/{s}"] for s in ("min", "max", "mean", "std", "count", "q01", "q50", "q99")} for r in rows
    ]


def _close(got: dict[str, Any], want: dict[str, Any], rtol: float = 1e-7) -> None:
    for s, v in got.items():
        np.testing.assert_allclose(
            np.asarray(v, dtype=float), np.asarray(want[s], dtype=float), rtol=rtol, atol=1e-9, err_msg=s
        )


def _hist(frames: list[np.ndarray]) -> ImageStatsAccumulator:
    acc = ImageStatsAccumulator()
    for f in frames:
        acc.add(f)
    return acc


@pytest.mark.parametrize("with_success", [True, False], ids=["next.success", "no-success+environment_state"])
def test_recompute_a_tampered_lerobot_dataset(tmp_path: Path, with_success: bool) -> None:
    clean = tmp_path / "clean"
    write_lerobot_dataset(clean, with_success=with_success, image_camera=True, environment_state=not with_success)
    src = shutil.copytree(clean, tmp_path / "tampered")
    _tamper(src)
    before = digest(src)
    out = tmp_path / "out"
    res = run_cli("stats", "recompute", str(src), "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith(f"recomputed: {out}  episodes 3  frames {sum(LENGTHS)}")
    assert check(out, deep=True) == []
    loaded = loaded_episodes(out)
    for g, w in zip(loaded, loaded_episodes(clean), strict=True):
        same_frames(g, w)
    stats = json.loads((out / "meta/stats.json").read_text())

    # numeric features: lerobot's own min/max/mean/std/count of the clean recording, and our writer's quantiles
    rows = pq.read_table(out / "data").sort_by("index")
    for key in ("observation.state", "action") if with_success else ("observation.state", "action", ENV_STATE):
        values = np.asarray(rows.column(key).to_pylist(), dtype=np.float32)
        starts = np.cumsum([0, *LENGTHS])
        for e, (got, theirs) in enumerate(zip(_episode_stats(out, key), _episode_stats(clean, key), strict=True)):
            _close({s: got[s] for s in ("min", "max", "mean", "std", "count")}, theirs, rtol=1e-6)  # theirs: float32
            _close(got, to_jsonable(numeric_stats(values[starts[e] : starts[e + 1]])))
        _close({s: stats[key][s] for s in ("min", "max", "mean", "std", "count")}, numeric_stats(values))

    # cameras: the writer's histograms of the pixels (the image camera's PNGs are lossless: its source pixels; the
    # video camera's: its frames as lerobot decodes them), per episode and, exactly, for the dataset
    pictures = {
        IMAGE_CAMERA: [[image_pixels(e, t) for t in range(n)] for e, n in enumerate(LENGTHS)],
        VIDEO_CAMERA: [[np.round(f["cam"] * 255).astype(np.uint8).transpose(1, 2, 0) for f in ep] for ep in loaded],
    }
    for key, episodes in pictures.items():
        for got, frames in zip(_episode_stats(out, key), episodes, strict=True):
            _close(got, to_jsonable(_hist(frames).stats()))
        _close(stats[key], to_jsonable(_hist([f for ep in episodes for f in ep]).stats()))
    assert digest(src) == before
    res = run_cli("stats", "recompute", str(src), "--in-place")  # lerobot's empty images/ folders are no obstacle
    assert res.returncode == 0, res.stderr
    assert json.loads((src / "meta/stats.json").read_text()) == stats
    assert _episode_stats(src, IMAGE_CAMERA) == _episode_stats(out, IMAGE_CAMERA)
    assert not (src / "images").exists() and check(src, deep=True) == []


@pytest.mark.slow
def test_recompute_our_tampered_dataset_in_place_gives_the_recordings_numbers(project: Path, tmp_path: Path) -> None:
    from tests.edit.test_edit import _record

    recorded = _record(project, tmp_path / "rec", 0, 3)
    ds = shutil.copytree(recorded, tmp_path / "ds")
    _tamper(ds)
    (ds / ".openral/image_hist.json").unlink()
    res = run_cli("stats", "recompute", str(ds), "--in-place")
    assert res.returncode == 0, res.stderr
    assert check(ds, deep=True) == []
    want, got = (json.loads((p / "meta/stats.json").read_text()) for p in (recorded, ds))
    assert got.keys() == want.keys()
    cameras = [k for k in want if k.startswith("observation.images.")]
    for key in want.keys() - set(cameras):  # numbers: exactly the recording's, per episode and for the dataset
        assert got[key] == want[key], key
        assert _episode_stats(ds, key) == _episode_stats(recorded, key), key
    hist = json.loads((ds / ".openral/image_hist.json").read_text())  # exact histograms again: resumable
    for key in cameras:  # the decoded pixels of a lossy video are close to the recorded ones, not equal
        np.testing.assert_allclose(np.asarray(got[key]["mean"]), np.asarray(want[key]["mean"]), atol=0.02)
        assert got[key]["count"] == want[key]["count"]
        assert hist[key.removeprefix("observation.images.")]["frames"] == want[key]["count"][0]


def test_stats_of_a_dataset_still_prints_the_report(tmp_path: Path) -> None:
    root = tmp_path / "recompute"  # a folder named like the subcommand is reached as ./recompute
    write_lerobot_dataset(root, with_success=True)
    for arg in (str(root), f"./{root.name}"):
        res = run_cli("stats", arg, "--format", "json", cwd=tmp_path)
        assert res.returncode == 0, res.stderr
        assert json.loads(res.stdout)["groups"][0]["episodes"] == len(LENGTHS)
    res = run_cli("stats", "--by", "task", str(root), "--format", "json")
    assert res.returncode == 0 and json.loads(res.stdout)["groups"][0]["task"] == "push the block", res.stderr
