"""`episodes resample --fps N`: output frame j is source frame floor(j * F / N) (every k-th frame for an integer
ratio k = F / N): its state, action and task exactly, its pixels within codec loss (videos re-encoded at N fps);
`info.fps` and every video's `video.fps` say N, timestamps are j / N, `doctor --deep` is clean and lerobot 0.6.1
loads it; upsampling and nonsense rates are refused in one line with nothing written."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from openral_data.doctor import check
from openral_data.edit.resample import source_frames
from tests.edit.test_trim import edited
from tests.support import quality as q
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import LENGTHS, loaded_episodes, write_lerobot_dataset

KEY = "observation.images.cam"


def test_the_rule_keeps_every_kth_frame_or_the_frame_at_or_before() -> None:
    assert source_frames(6, 10, 5) == [0, 2, 4]
    assert source_frames(7, 10, 5) == [0, 2, 4, 6]
    assert source_frames(9, 30, 10) == [0, 3, 6]
    assert source_frames(10, 30, 20) == [0, 1, 3, 4, 6, 7, 9]  # j * 1.5, rounded down
    assert source_frames(10, 10, 4) == [0, 2, 5, 7]
    assert source_frames(1, 10, 3) == [0]


@pytest.fixture(scope="module")
def ours(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return q.write(tmp_path_factory.mktemp("resample") / "ds", [q.moving(12, 0), q.moving(9, 1)])


def _check(src: Path, out: Path, fps: int, exact: bool = False) -> None:
    """`out` is `src` at `fps`, frame by frame (the module's rule); pixels equal when `exact`."""
    info = json.loads((out / "meta/info.json").read_text())
    assert info["fps"] == fps and info["features"][KEY]["info"]["video.fps"] == fps
    old_fps = json.loads((src / "meta/info.json").read_text())["fps"]
    want, got = loaded_episodes(src), loaded_episodes(out)  # (the loader checks timestamps are t / fps)
    assert [len(g) for g in got] == [len(source_frames(len(w), old_fps, fps)) for w in want]
    for g, w in zip(got, want, strict=True):
        for frame, k in zip(g, source_frames(len(w), old_fps, fps), strict=True):
            assert (frame["state"], frame["action"], frame["task"]) == (w[k]["state"], w[k]["action"], w[k]["task"])
            assert float(np.abs(frame["cam"] - w[k]["cam"]).mean()) < 0.06
            assert np.array_equal(frame["cam"], w[k]["cam"]) or not exact


@pytest.mark.slow
def test_our_dataset_at_a_non_integer_ratio(ours: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    said = edited(ours, out, "episodes", "resample", str(ours), "--fps", "4", "--out", str(out))
    assert said.splitlines() == [
        f"resampled: {out}  episodes 2  frames 9",  # ceil(12 * 4 / 10) + ceil(9 * 4 / 10)
        "resampled: camera clips: 0 keyframes copied, 2 re-encoded",  # frames 0, 2, 5, 7: 5 is no keyframe
    ]
    _check(ours, out, 4)


@pytest.mark.slow
def test_halving_keeps_only_keyframes_so_their_packets_are_copied(ours: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    said = edited(ours, out, "episodes", "resample", str(ours), "--fps", "5", "--out", str(out))
    assert "camera clips: 2 keyframes copied, 0 re-encoded" in said  # AV1, g=2: every even frame is a keyframe
    _check(ours, out, 5, exact=True)


@pytest.mark.slow
def test_a_lerobot_dataset_halved_in_place(tmp_path: Path) -> None:
    src = tmp_path / "ds"
    write_lerobot_dataset(src, with_success=True)
    keep = tmp_path / "before"
    shutil.copytree(src, keep)
    res = run_inproc("episodes", "resample", str(src), "--fps", "5", "--in-place")
    assert res.returncode == 0, res.stderr
    assert f"resampled: {src}  episodes 3  frames {sum((n + 1) // 2 for n in LENGTHS)}" in res.stdout
    assert check(src, deep=True) == []
    _check(keep, src, 5)
    # a successful episode's last frame still says so, though the source's last frame was not kept
    assert [f["success"] for f in loaded_episodes(src)[2]] == [False, True]


def test_bad_rates_are_one_line_and_write_nothing(ours: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    for fps, message in (
        ("20", f"error: --fps: 20 is not below {ours}'s 10 fps (resample only lowers the frame rate)"),
        ("10", f"error: --fps: {ours} is already at 10 fps"),
        ("0", "error: --fps: 0 is not a positive frame rate"),
        ("-3", "error: --fps: -3 is not a positive frame rate"),
    ):
        res = run_inproc("episodes", "resample", str(ours), "--fps", fps, "--out", str(out))
        assert (res.returncode, res.stderr.strip()) == (2, message), fps
        assert not out.exists()
