"""SIGKILL `record` at random moments (startup, recovery, mid-episode, inside a commit, while joining videos
at close), again and again on the same dataset: after every kill lerobot 0.6.1 loads the killed dataset
directly with every episode record reported finished, frame-exact; `--resume` then completes the count."""

from __future__ import annotations

import json
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import mock_scene, write_yaml
from lerobot_check import verify_mock_dataset

from openral_data.doctor import check
from openral_data.sinks.lerobot_v3 import layout
from openral_data.sinks.mcap.writer import finished_bags

DRIVER = Path(__file__).with_name("record_driver.py")
LENGTHS = [5, 7, 4]
TARGET = 40
KILLS = 8


def expected(n: int) -> list[int]:
    return [LENGTHS[e % len(LENGTHS)] for e in range(n)]


def run_and_kill(args: dict[str, object], delay: float) -> tuple[list[int], bool]:
    """Start record_driver.py, SIGKILL it after `delay` s; the episodes it reported and whether it ended first."""
    proc = subprocess.Popen([sys.executable, str(DRIVER), json.dumps(args)], stdout=subprocess.PIPE, text=True)
    time.sleep(delay)
    ended = proc.poll() is not None
    proc.send_signal(signal.SIGKILL)
    out, _ = proc.communicate(timeout=60)
    return [int(line.split()[1]) for line in out.splitlines() if line.startswith("finished ")], ended


@pytest.mark.slow
def test_sigkill_at_random_moments_then_resume(tmp_path: Path, project: Path) -> None:
    scene = write_yaml(tmp_path / "scene.yaml", mock_scene(success_after=LENGTHS, n_episodes=TARGET))
    out = tmp_path / "ds"
    rng = random.Random(20261121)
    reported: list[int] = []
    landed = 0  # kills that interrupted a recording in progress
    log: list[str] = []
    for k in range(KILLS):
        args = {"scene": str(scene), "out": str(out), "n": TARGET, "formats": ["lerobot", "mcap"], "resume": k > 0}
        done, ended = run_and_kill(args, rng.uniform(2.0, 14.0))
        assert done == sorted(done) and (
            not reported or not done or done[0] == reported[-1] + 1 or done[0] <= reported[-1] + 1
        )
        reported += [e for e in done if e not in reported]
        landed += not ended
        if not (out / layout.INFO_PATH).exists():
            assert reported == [], "a reported episode must leave a dataset"
            continue
        seen = verify_mock_dataset(out, "pyav", uncounted_rows_ok=True)  # lerobot on the killed dataset
        assert len(seen["lengths"]) >= len(reported), (seen["lengths"], reported)
        assert seen["lengths"] == expected(len(seen["lengths"]))
        assert len(finished_bags(out / "mcap")) >= len(reported)
        if ended:
            break
    print("\n".join(log))
    assert landed >= 3, f"only {landed} kill(s) landed inside a recording"
    final = subprocess.run(
        [sys.executable, str(DRIVER), json.dumps({"out": str(out), "n": TARGET, "resume": True})],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert final.returncode == 0, final.stderr
    seen = verify_mock_dataset(out, "pyav")
    assert seen["lengths"] == expected(TARGET)
    assert [b.name for b in finished_bags(out / "mcap")] == [f"episode_{i:06d}" for i in range(TARGET)]
    assert check(out) == []
