"""`record --save-video [--save-video-dir PATH]` through the real CLI on the mock scene: one h264 mp4 per
committed episode showing the cameras and a strip, the dataset byte-identical to a run without it, nothing left
for a discarded or interrupted episode, the numbering continued by `--resume`, and the refusals."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from openral_data.viz.debug_video import existing_videos
from tests.support.cli import run_cli
from tests.support.debug_video import check_mock_video, leftovers
from tests.support.lerobot import verify_mock_dataset
from tests.support.scenes import mock_scene, write_yaml
from tests.support.timing import TIMED

LENGTHS = [5, 7, 3]


def _scene(tmp_path: Path, **over: object) -> Path:
    return write_yaml(tmp_path / "scene.yaml", mock_scene(success_after=LENGTHS, **over))  # type: ignore[arg-type]


def _record(scene: Path, out: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    return run_cli("record", "--scene", str(scene), "--out", str(out), "--codec", "h264", *extra, timeout=300)


def _data_files(root: Path) -> dict[str, bytes]:
    """What lerobot reads: meta/, data/ and videos/ (`.openral/` holds this run's own bookkeeping)."""
    return {
        str(p.relative_to(root)): p.read_bytes()
        for top in ("meta", "data", "videos")
        for p in sorted((root / top).rglob("*"))
        if p.is_file()
    }


@pytest.mark.slow
def test_one_video_per_episode_beside_an_unchanged_dataset(tmp_path: Path, project: Path) -> None:
    scene = _scene(tmp_path, n_episodes=3)
    out = tmp_path / "ds"
    done = _record(scene, out, "--save-video")
    assert done.returncode == 0, done.stderr
    folder = tmp_path / "ds.debug"
    assert "debug videos" in done.stdout  # the summary says where they went
    assert existing_videos(folder) == [0, 1, 2] and leftovers(folder) == []
    for episode, length in enumerate(LENGTHS):
        check_mock_video(folder / f"episode_{episode:06d}.mp4", episode, length)
    # the dataset is what a run without --save-video writes, byte for byte; lerobot and doctor agree
    plain = tmp_path / "plain"
    assert _record(scene, plain).returncode == 0
    assert _data_files(out) == _data_files(plain)
    assert verify_mock_dataset(out, "pyav")["lengths"] == LENGTHS
    doctor = run_cli("doctor", str(out), timeout=120)
    assert doctor.returncode == 0, doctor.stdout + doctor.stderr
    assert not list(out.rglob("*.mp4.partial")) and not list(out.rglob("episode_*.mp4"))


@pytest.mark.slow
def test_save_video_dir_and_resume_continue_the_numbering(tmp_path: Path, project: Path) -> None:
    scene = _scene(tmp_path, n_episodes=2)
    out, folder = tmp_path / "ds", tmp_path / "elsewhere" / "videos"
    assert _record(scene, out, "--save-video-dir", str(folder)).returncode == 0
    assert existing_videos(folder) == [0, 1] and not (tmp_path / "ds.debug").exists()
    first = (folder / "episode_000000.mp4").read_bytes()
    done = run_cli(
        "record",
        "--resume",
        "--out",
        str(out),
        "--n-episodes",
        "3",
        "--scene",
        str(scene),
        "--save-video-dir",
        str(folder),
    )
    assert done.returncode == 0, done.stderr
    assert existing_videos(folder) == [0, 1, 2] and leftovers(folder) == []
    assert (folder / "episode_000000.mp4").read_bytes() == first  # what was there stays as it was
    check_mock_video(folder / "episode_000002.mp4", 2, LENGTHS[2])
    assert verify_mock_dataset(out, "pyav")["lengths"] == LENGTHS


@pytest.mark.slow
def test_a_discarded_episode_leaves_no_video(tmp_path: Path, project: Path) -> None:
    scene = _scene(tmp_path, n_episodes=3, fault={"kind": "nan_state", "at_step": 2, "episode": 1})
    out = tmp_path / "ds"
    done = _record(scene, out, "--save-video")
    assert done.returncode == 2 and done.stderr.startswith("error: episode 1 step 2"), done.stderr
    folder = tmp_path / "ds.debug"
    assert existing_videos(folder) == [0] and leftovers(folder) == []
    check_mock_video(folder / "episode_000000.mp4", 0, LENGTHS[0])


@pytest.mark.slow
@TIMED
def test_ctrl_c_leaves_a_video_for_each_kept_episode_only(tmp_path: Path, project: Path) -> None:
    scene = write_yaml(tmp_path / "long.yaml", mock_scene(success_after=60, max_steps=60, n_episodes=1000))
    out = tmp_path / "ds"
    cmd = [sys.executable, "-m", "openral_data.cli", "record", "--scene", str(scene), "--out", str(out)]
    proc = subprocess.Popen(
        [*cmd, "--codec", "h264", "--save-video"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=dict(os.environ),
    )
    info = out / "meta/info.json"
    deadline = time.monotonic() + 120
    while not (info.exists() and json.loads(info.read_text())["total_episodes"] >= 1):
        if time.monotonic() > deadline or proc.poll() is not None:
            proc.kill()
            pytest.fail("no episode finished in time")
        time.sleep(0.05)
    time.sleep(0.3)  # inside a later episode
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130 and "Traceback" not in err, err
    kept = json.loads(info.read_text())["total_episodes"]
    folder = tmp_path / "ds.debug"
    assert existing_videos(folder) == list(range(kept)) and leftovers(folder) == []
    for episode in range(kept):
        check_mock_video(folder / f"episode_{episode:06d}.mp4", episode, 60)


@pytest.mark.slow
def test_refusals_are_one_line_and_write_nothing(tmp_path: Path, project: Path) -> None:
    scene = _scene(tmp_path, n_episodes=1)
    out = tmp_path / "ds"
    # a folder that already holds debug videos: nothing there is replaced, no dataset is started
    folder = tmp_path / "videos"
    folder.mkdir()
    (folder / "episode_000000.mp4").write_bytes(b"canary")
    done = _record(scene, out, "--save-video-dir", str(folder))
    assert done.returncode == 2 and done.stderr.startswith(f"error: {folder}: --save-video-dir: already holds")
    assert (folder / "episode_000000.mp4").read_bytes() == b"canary" and not out.exists()
    # inside the dataset folder (its readers must see it unchanged)
    done = _record(scene, out, "--save-video-dir", str(out / "debug"))
    assert done.returncode == 2 and "inside the dataset" in done.stderr.splitlines()[0] and not out.exists()
    # with --workers (the shares are merged at the end) and with --hal
    for extra in (["--workers", "2"], ["--hal", "mock_arm"]):
        done = _record(scene, out, "--save-video", *extra)
        assert done.returncode == 2 and done.stderr.startswith("error: --save-video"), (extra, done.stderr)
        assert "Traceback" not in done.stderr and not out.exists()
    assert not (tmp_path / "ds.debug").exists()
