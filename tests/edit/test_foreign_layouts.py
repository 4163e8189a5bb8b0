"""Editing a dataset shaped like lerobot/pusht (camera key `observation.image`, names in lerobot's
`{"motors": [...]}` form, `next.reward`, `next.success`), written by lerobot 0.6.1: every edit command takes it,
and its output keeps those features verbatim, is `doctor --deep` healthy and loads in lerobot with the source's
frames (decoded pixels equal where packets are copied, within codec loss where re-encoded); the source stays
byte-unchanged."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from openral_data.doctor import check
from tests.support.cli import run_cli
from tests.support.lerobot_written import digest
from tests.support.pusht_like import CAMERA_KEY, LENGTHS, NAMES, TASK, grey, write_pusht_like

Frame = dict[str, Any]


@pytest.fixture(scope="module")
def pusht(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("pusht") / "pusht_like"
    write_pusht_like(root)
    return root


def _features(root: Path) -> dict[str, Any]:
    features: dict[str, Any] = json.loads((root / "meta/info.json").read_text())["features"]
    return features


def _loaded(root: Path) -> list[list[Frame]]:
    """Every frame lerobot 0.6.1 loads, grouped by episode."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/check", root=root, video_backend="pyav")
    out: list[list[Frame]] = [[] for _ in range(ds.meta.total_episodes)]
    for i in range(len(ds)):
        item = ds[i]
        assert int(item["index"]) == i
        e, t = int(item["episode_index"]), int(item["frame_index"])
        assert len(out[e]) == t
        out[e].append(
            {
                "state": item["observation.state"].numpy().tolist(),
                "action": item["action"].numpy().tolist(),
                "reward": float(item["next.reward"]) if "next.reward" in item else None,
                "success": bool(item["next.success"]),
                "task": item["task"],
                "pixels": item[CAMERA_KEY].numpy(),  # (3, H, W) floats in [0, 1]
            }
        )
    return out


def _same(got: list[Frame], want: list[Frame], *, exact: bool, reward: bool = True) -> None:
    assert len(got) == len(want)
    for g, w in zip(got, want, strict=True):
        assert g["state"] == w["state"] and g["action"] == w["action"]
        assert g["success"] == w["success"] and g["task"] == w["task"]
        assert g["reward"] == (w["reward"] if reward else None)
        if exact:  # packets copied: the decoded pixels are the source's
            assert np.array_equal(g["pixels"], w["pixels"])
        else:  # re-encoded: a flat grey within codec loss
            assert np.abs(g["pixels"] - w["pixels"]).max() * 255 <= 3


def _checked(out: Path, source: Path, features: dict[str, Any] | None = None) -> list[list[Frame]]:
    """`doctor --deep` healthy, the source's features verbatim (or `features`), the camera's files under its key."""
    assert check(out, deep=True) == []
    got = _features(out)
    assert got == (features if features is not None else _features(source))
    assert got["observation.state"]["names"] == {"motors": NAMES} and got["action"]["names"] == {"motors": NAMES}
    assert list((out / "videos" / CAMERA_KEY).glob("chunk-*/file-*.mp4"))
    assert not (out / "videos" / "observation.images.image").exists()
    return _loaded(out)


@pytest.mark.slow
def test_episode_edits_of_a_pusht_like_dataset(pusht: Path, tmp_path: Path) -> None:
    before = digest(pusht)
    src = _loaded(pusht)
    assert [len(e) for e in src] == LENGTHS and src[0][0]["task"] == TASK
    assert abs(float(src[0][3]["pixels"].mean()) * 255 - grey(3)) <= 3
    runs = [
        ("episodes", "delete", str(pusht), "--episodes", "0", "--out", str(tmp_path / "del")),
        ("episodes", "filter", str(pusht), "--where", "success", "--out", str(tmp_path / "won")),
        ("episodes", "split", str(pusht), "--fractions", "0.5,0.5", "--names", "a,b", "--out-dir", str(tmp_path / "p")),
    ]
    for args in runs:
        res = run_cli(*args)
        assert res.returncode == 0, res.stderr
    parts = [tmp_path / "p/a", tmp_path / "p/b"]
    firsts = sorted(int(_loaded(p)[0][0]["action"][1] == -1) for p in parts)  # action[1] is -episode
    assert firsts == [0, 1]  # one episode each
    for out in (tmp_path / "del", tmp_path / "won", *parts):
        got = _checked(out, pusht)
        assert len(got) == 1
        e = int(-got[0][0]["action"][1])
        assert out.name not in ("del", "won") or e == {"del": 1, "won": 0}[out.name]
        _same(got[0], src[e], exact=True)
    assert digest(pusht) == before


@pytest.mark.slow
def test_merge_of_two_pusht_like_datasets(pusht: Path, tmp_path: Path) -> None:
    other = tmp_path / "other"
    shutil.copytree(pusht, other)
    before = digest(pusht), digest(other)
    out = tmp_path / "merged"
    res = run_cli("episodes", "merge", str(pusht), str(other), "--out", str(out))
    assert res.returncode == 0, res.stderr
    got = _checked(out, pusht)
    src = _loaded(pusht)
    assert len(got) == 2 * len(LENGTHS)
    for g, w in zip(got, src + src, strict=True):
        _same(g, w, exact=True)
    assert (digest(pusht), digest(other)) == before


@pytest.mark.slow
def test_tasks_features_and_stats_of_a_pusht_like_dataset(pusht: Path, tmp_path: Path) -> None:
    before = digest(pusht)
    src = _loaded(pusht)
    renamed, slim, restated = tmp_path / "renamed", tmp_path / "slim", tmp_path / "restated"
    for args in [
        ("tasks", "rename", str(pusht), "--from", TASK, "--to", "push", "--out", str(renamed)),
        ("features", "remove", str(pusht), "--feature", "next.reward", "--out", str(slim)),
        ("stats", "recompute", str(pusht), "--out", str(restated)),
    ]:
        res = run_cli(*args)
        assert res.returncode == 0, res.stderr
    for g, w in zip(_checked(renamed, pusht), src, strict=True):
        _same(g, [{**f, "task": "push"} for f in w], exact=True)
    without = {k: f for k, f in _features(pusht).items() if k != "next.reward"}
    for g, w in zip(_checked(slim, pusht, without), src, strict=True):
        _same(g, w, exact=True, reward=False)
    for g, w in zip(_checked(restated, pusht), src, strict=True):
        _same(g, w, exact=True)
    stats = json.loads((restated / "meta/stats.json").read_text())
    assert stats[CAMERA_KEY]["count"] == [sum(LENGTHS)]  # the camera's statistics, under its own key
    assert digest(pusht) == before


@pytest.mark.slow
@pytest.mark.parametrize("camera", ["image", CAMERA_KEY])
def test_videos_reencode_of_a_pusht_like_dataset(pusht: Path, tmp_path: Path, camera: str) -> None:
    before = digest(pusht)
    out = tmp_path / "h264"
    res = run_cli("videos", "reencode", str(pusht), "--codec", "h264", "--camera", camera, "--out", str(out))
    assert res.returncode == 0, res.stderr
    assert check(out, deep=True) == []
    features = _features(out)
    assert features[CAMERA_KEY]["dtype"] == "video" and features[CAMERA_KEY]["info"]["video.codec"] == "h264"
    assert {k: f for k, f in features.items() if k != CAMERA_KEY} == {
        k: f for k, f in _features(pusht).items() if k != CAMERA_KEY
    }
    assert json.loads((out / "meta/openral.json").read_text())["edit"]["cameras"] == [CAMERA_KEY]
    for g, w in zip(_checked(out, pusht, features), _loaded(pusht), strict=True):
        _same(g, w, exact=False)
    assert digest(pusht) == before


@pytest.mark.slow
def test_videos_encode_images_of_a_pusht_like_image_camera(tmp_path: Path) -> None:
    source = tmp_path / "pusht_images"
    write_pusht_like(source, camera_dtype="image")
    assert _features(source)[CAMERA_KEY]["dtype"] == "image"
    before = digest(source)
    out = tmp_path / "videos"
    res = run_cli("videos", "encode-images", str(source), "--camera", "image", "--codec", "h264", "--out", str(out))
    assert res.returncode == 0, res.stderr
    features = _features(out)
    assert features[CAMERA_KEY]["dtype"] == "video" and features[CAMERA_KEY]["info"]["video.codec"] == "h264"
    assert {k: f for k, f in features.items() if k != CAMERA_KEY} == {
        k: f for k, f in _features(source).items() if k != CAMERA_KEY
    }
    for g, w in zip(_checked(out, source, features), _loaded(source), strict=True):
        _same(g, w, exact=False)
    assert digest(source) == before


def test_videos_camera_names_the_cameras_it_knows(pusht: Path, tmp_path: Path) -> None:
    out = tmp_path / "x"
    res = run_cli("videos", "reencode", str(pusht), "--codec", "h264", "--camera", "top", "--out", str(out))
    assert res.returncode == 2 and res.stderr.count("\n") == 1, res.stderr
    assert res.stderr == f"error: --camera: 'top' is not a feature of {pusht} (video cameras: {CAMERA_KEY})\n"
    assert not out.exists()
