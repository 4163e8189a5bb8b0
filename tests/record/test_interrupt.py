"""Ctrl-C / SIGTERM during a recording: the episode in flight is dropped, every finished one stays loadable."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tests.support.lerobot import verify_mock_dataset
from tests.support.scenes import mock_scene, write_yaml
from tests.support.timing import TIMED

pytestmark = TIMED


@pytest.mark.slow
@pytest.mark.parametrize(("sig", "delay"), [(signal.SIGINT, 0.0), (signal.SIGINT, 0.37), (signal.SIGTERM, 0.2)])
def test_stop_signal_keeps_finished_episodes(tmp_path: Path, project: Path, sig: int, delay: float) -> None:
    scene = write_yaml(tmp_path / "long.yaml", mock_scene(success_after=60, max_steps=60, n_episodes=1000))
    out = tmp_path / "ds"
    proc = subprocess.Popen(
        [sys.executable, "-m", "openral_data.cli", "record", "--scene", str(scene), "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=dict(os.environ),
    )
    info = out / "meta/info.json"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if info.exists() and json.loads(info.read_text())["total_episodes"] >= 1:
            break
        time.sleep(0.05)
    else:
        proc.kill()
        pytest.fail("no episode finished in time")
    time.sleep(delay)  # land somewhere inside a later episode
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    assert f"continue it: openral-data record --resume --out {out}\n" in err  # the command that continues it
    finished = json.loads(info.read_text())["total_episodes"]
    assert finished >= 1
    seen = verify_mock_dataset(out, "pyav")
    assert seen["lengths"] == [60] * finished
    assert not list(out.rglob("*.tmp"))
    # after a clean stop, each camera's episodes were joined into one file
    assert all(len(list((out / "videos" / k).glob("*/*.mp4"))) == 1 for k in seen["video_keys"])
