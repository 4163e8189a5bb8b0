"""`features remove`: the features named are gone from the data, the videos, info.json, stats.json and the
episodes' stats columns; everything else loads in lerobot 0.6.1 exactly as in the source; doctor finds the result
healthy; the source is unchanged; lerobot's required columns, state and action are refused in one line."""

from __future__ import annotations

import json
from pathlib import Path

import pyarrow.parquet as pq
import pytest

from openral_data.doctor import check
from openral_data.edit import features
from openral_data.errors import UsageError
from tests.support.cli import run_cli
from tests.support.lerobot_written import (
    ENV_STATE,
    IMAGE_CAMERA,
    LENGTHS,
    VIDEO_CAMERA,
    digest,
    loaded_episodes,
    same_frames,
    write_lerobot_dataset,
)
from tests.support.seeded import verify_seeded_dataset


@pytest.fixture(scope="module")
def source(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("features") / "lerobot"
    write_lerobot_dataset(root, with_success=True, image_camera=True, environment_state=True)
    return root


def _gone(out: Path, keys: list[str]) -> None:
    info = json.loads((out / "meta/info.json").read_text())
    stats = json.loads((out / "meta/stats.json").read_text())
    columns = pq.read_table(out / "meta/episodes").column_names + pq.read_table(out / "data").column_names
    for key in keys:
        assert key not in info["features"] and key not in stats, key
        assert not [c for c in columns if key in c], key
        assert not (out / "videos" / key).exists(), key


@pytest.mark.parametrize(
    ("removed", "blank"),
    [
        ([VIDEO_CAMERA], ["cam"]),
        ([IMAGE_CAMERA, ENV_STATE, "next.success"], ["wrist", "env", "success"]),
    ],
    ids=["video-camera", "image-camera+environment_state+next.success"],
)
def test_remove_from_a_lerobot_dataset(source: Path, tmp_path: Path, removed: list[str], blank: list[str]) -> None:
    before = digest(source)
    want = loaded_episodes(source)
    out = tmp_path / "out"
    args = [a for key in removed for a in ("--feature", key)]
    res = run_cli("features", "remove", str(source), *args, "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith(f"removed: {out}  episodes 3  frames {sum(LENGTHS)}")
    assert check(out, deep=True) == []
    _gone(out, removed)
    info, src_info = (json.loads((p / "meta/info.json").read_text()) for p in (out, source))
    assert info["features"] == {k: f for k, f in src_info["features"].items() if k not in removed}
    got = loaded_episodes(out)
    for g, w in zip(got, want, strict=True):
        same_frames(g, [dict(f, **dict.fromkeys(blank)) for f in w])
    rows = pq.read_table(out / "meta/episodes").to_pylist()
    assert [r["openral.success"] for r in rows] == ([None] * 3 if "next.success" in removed else [True, False, True])
    assert digest(source) == before


def test_remove_a_camera_of_our_dataset_in_place(project: Path, tmp_path: Path) -> None:
    from tests.edit.test_edit import _record

    ds = _record(project, tmp_path / "ours", 0, 3)
    res = run_cli("features", "remove", str(ds), "--feature", "observation.images.wrist", "--in-place")
    assert res.returncode == 0, res.stderr
    _gone(ds, ["observation.images.wrist"])
    assert check(ds, deep=True) == []
    verify_seeded_dataset(ds)  # every episode still holds exactly its own frames
    assert (ds / ".openral/image_hist.json").is_file()  # the other camera's statistics stay exact


@pytest.mark.parametrize(
    ("feature", "first_line"),
    [
        ("index", "error: --feature: index is a column every LeRobot v3 dataset has; it cannot be removed"),
        ("task_index", "error: --feature: task_index is a column every LeRobot v3 dataset has"),
        ("action", "error: --feature: action cannot be removed: openral-data writes observation.state and action"),
        ("observation.state", "error: --feature: observation.state cannot be removed"),
        ("nope", "error: --feature: {src} has no feature 'nope' (its features: "),
    ],
)
def test_refusals_are_one_line_and_write_nothing(source: Path, tmp_path: Path, feature: str, first_line: str) -> None:
    before = digest(source)
    res = run_cli("features", "remove", str(source), "--feature", feature, "--out", str(tmp_path / "o"))
    assert res.returncode == 2 and res.stderr.count("\n") == 1, res.stderr
    assert res.stderr.startswith(first_line.format(src=source)), res.stderr
    assert not (tmp_path / "o").exists() and digest(source) == before


def test_needs_a_feature(source: Path, tmp_path: Path) -> None:
    with pytest.raises(UsageError, match="--feature: give at least one feature"):
        features.remove(source, [], tmp_path / "o")
