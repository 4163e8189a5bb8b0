"""Editing datasets lerobot 0.6.1 wrote itself (no `openral.*` columns, a video and a `dtype: image` camera):
delete, split and merge give datasets that `doctor` finds healthy and lerobot loads with exactly the source's
frames (decoded pixels of both cameras included); the sources stay byte-unchanged."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import pytest

from openral_data.doctor import check
from openral_data.edit import ops, select
from tests.support.cli import run_cli
from tests.support.lerobot_written import (
    IMAGE_CAMERA,
    LENGTHS,
    SUCCEEDED,
    digest,
    loaded_episodes,
    same_frames,
    write_lerobot_dataset,
)


def _healthy(root: Path) -> None:
    assert check(root, deep=True) == []  # doctor: healthy, every frame decodes


@pytest.fixture(params=[True, False], ids=["next.success", "no-success+environment_state"])
def source(request: pytest.FixtureRequest, tmp_path: Path) -> Path:
    root = tmp_path / "lerobot"
    write_lerobot_dataset(root, with_success=request.param, image_camera=True, environment_state=not request.param)
    return root


def test_delete_and_split_of_a_lerobot_dataset(source: Path, tmp_path: Path) -> None:
    before = digest(source)
    src = loaded_episodes(source)
    assert [len(e) for e in src] == LENGTHS
    res = run_cli("episodes", "delete", str(source), "--episodes", "1", "--out", str(tmp_path / "del"))
    assert res.returncode == 0, res.stderr
    ops.split(source, "2,0", tmp_path / "part", rest=tmp_path / "rest")
    res = run_cli("episodes", "filter", str(source), "--where", "length >= 6", "--out", str(tmp_path / "long"))
    assert res.returncode == 0, res.stderr
    parts = select.split_fractions(source, "0.67,0.33", tmp_path / "parts", names="a,b", seed=1)
    fractions = [(r.out, select.partition(len(LENGTHS), [0.67, 0.33], 1)[k]) for k, r in enumerate(parts)]
    has_env = "observation.environment_state" in json.loads((source / "meta/info.json").read_text())["features"]
    assert all((f["env"] is not None) == has_env and f["wrist"] is not None for e in src for f in e)
    outs = [
        (tmp_path / "del", [0, 2]),
        (tmp_path / "part", [2, 0]),
        (tmp_path / "rest", [1]),
        (tmp_path / "long", [0, 1]),
    ]
    for out, order in outs + fractions:
        _healthy(out)
        got = loaded_episodes(out)
        assert len(got) == len(order)
        for k, e in enumerate(order):
            same_frames(got[k], src[e])
        rows = pq.read_table(out / "meta/episodes").to_pylist()
        with_success = "next.success" in json.loads((source / "meta/info.json").read_text())["features"]
        assert [r["openral.success"] for r in rows] == [SUCCEEDED[e] if with_success else None for e in order]
        assert [r["openral.seed"] for r in rows] == [None] * len(order)  # unknown stays unknown
        info = json.loads((out / "meta/info.json").read_text())
        assert info["features"] == json.loads((source / "meta/info.json").read_text())["features"]
        assert info["total_episodes"] == len(order) and info["total_frames"] == sum(LENGTHS[e] for e in order)
        _same_image_cells(out, source, order)
        _image_stats_carried(out, source, order)
    assert digest(source) == before


def _image_cells(root: Path) -> list[dict[str, Any]]:
    table = pq.read_table(root / "data").sort_by("index")
    return table.column(IMAGE_CAMERA).to_pylist()


def _same_image_cells(out: Path, source: Path, order: list[int]) -> None:
    """The image column is carried as stored: every cell's bytes (and path) are the source's, in episode order."""
    cells = _image_cells(source)
    starts = [sum(LENGTHS[:e]) for e in range(len(LENGTHS))]
    want = [c for e in order for c in cells[starts[e] : starts[e] + LENGTHS[e]]]
    assert _image_cells(out) == want


def _image_stats_carried(out: Path, source: Path, order: list[int]) -> None:
    """Per-episode image statistics are the source's; the dataset's merge them (count = frames written)."""
    key = f"stats/{IMAGE_CAMERA}/mean"
    src_rows = pq.read_table(source / "meta/episodes").to_pylist()
    out_rows = pq.read_table(out / "meta/episodes").to_pylist()
    assert [r[key] for r in out_rows] == [src_rows[e][key] for e in order]
    stats = json.loads((out / "meta/stats.json").read_text())[IMAGE_CAMERA]
    assert stats["count"] == [sum(LENGTHS[e] for e in order)]
    assert np.asarray(stats["mean"]).shape == (3, 1, 1)


def test_merge_two_lerobot_datasets(tmp_path: Path) -> None:
    a, b = tmp_path / "a", tmp_path / "b"
    write_lerobot_dataset(a, with_success=True, image_camera=True)
    write_lerobot_dataset(b, with_success=True, image_camera=True)
    before = digest(a), digest(b)
    out = tmp_path / "merged"
    res = run_cli("episodes", "merge", str(a), str(b), "--out", str(out))
    assert res.returncode == 0, res.stderr
    _healthy(out)
    src = loaded_episodes(a) + loaded_episodes(b)
    got = loaded_episodes(out)
    assert len(got) == 2 * len(LENGTHS)
    for g, w in zip(got, src, strict=True):
        same_frames(g, w)
    assert (digest(a), digest(b)) == before


def test_merge_by_seed_needs_recorded_seeds(tmp_path: Path) -> None:
    a = tmp_path / "a"
    write_lerobot_dataset(a, with_success=False)
    out = tmp_path / "merged"
    res = run_cli("episodes", "merge", str(a), "--order", "seed", "--out", str(out))
    assert res.returncode == 2
    assert res.stderr.count("\n") == 1, res.stderr
    assert res.stderr.startswith(f"error: {a}: meta/episodes: openral.seed: no such column"), res.stderr
    assert "--order input" in res.stderr
    assert not out.exists()
    edited = tmp_path / "edited"  # an edit of it has the column, but no seed in it
    ops.delete(a, "0", edited)
    res = run_cli("episodes", "merge", str(edited), "--order", "seed", "--out", str(out))
    assert res.returncode == 2 and res.stderr.count("\n") == 1, res.stderr
    assert res.stderr.startswith(f"error: {edited}: meta/episodes: openral.seed: episode 0 has none"), res.stderr
    assert not out.exists()
    assert run_cli("episodes", "merge", str(edited), "--order", "input", "--out", str(out)).returncode == 0


def test_merge_of_ours_and_lerobots_names_the_differing_field(project: Path, tmp_path: Path) -> None:
    from tests.edit.test_edit import _record

    ours = _record(project, tmp_path / "ours", 0, 1)
    theirs = tmp_path / "theirs"
    write_lerobot_dataset(theirs, with_success=True)
    out = tmp_path / "merged"
    res = run_cli("episodes", "merge", str(ours), str(theirs), "--out", str(out))
    assert res.returncode == 2
    assert res.stderr.count("\n") == 1 and res.stderr.startswith(f"error: {theirs}/meta/info.json: "), res.stderr
    assert not out.exists()


def test_a_feature_the_writer_cannot_reproduce_is_refused_naming_it(tmp_path: Path) -> None:
    src = tmp_path / "with_image"
    write_lerobot_dataset(src, with_success=False)
    info = json.loads((src / "meta/info.json").read_text())
    info["features"]["observation.images.wrist"] = {"dtype": "image", "shape": [24, 20], "names": None}  # no channels
    (src / "meta/info.json").write_text(json.dumps(info, indent=4))
    before = digest(src)
    out = tmp_path / "out"
    res = run_cli("episodes", "delete", str(src), "--episodes", "0", "--out", str(out))
    assert res.returncode == 2 and res.stderr.count("\n") == 1, res.stderr
    assert res.stderr.startswith(f"error: {src}/meta/info.json: features.observation.images.wrist: "), res.stderr
    assert not out.exists() and digest(src) == before
