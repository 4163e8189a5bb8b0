"""SIGKILL `record` at random moments, again and again on the same dataset: during start-up or recovery
(a random delay from launch) and inside a running recording (a random delay after an episode was reported,
landing mid-episode, inside a commit or in between). After every kill lerobot 0.6.1 loads the killed dataset
directly with every episode record reported finished, frame-exact; `--resume` then completes the count."""

from __future__ import annotations

import json
import random
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from openral_data.doctor import check
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.mcap.writer import finished_bags
from tests.support.home import REPO
from tests.support.lerobot import verify_mock_dataset
from tests.support.scenes import mock_scene, write_yaml
from tests.support.timing import TIMED

pytestmark = TIMED

DRIVER = [sys.executable, "-m", "tests.support.record_driver"]  # run from REPO
LENGTHS = [5, 7, 4]
KILLS = 10
ENDLESS = 100_000  # episodes asked of each killed run: it never finishes before its kill


def expected(n: int) -> list[int]:
    return [LENGTHS[e % len(LENGTHS)] for e in range(n)]


def run_and_kill(args: dict[str, object], rng: random.Random, after_report: bool) -> list[int]:
    """Start the record driver (tests/support) and SIGKILL it: after_report -> a random 0-1.5 s after its first
    reported episode, else a random 0.2-5 s after launch. Returns the episodes it reported finished."""
    proc = subprocess.Popen([*DRIVER, json.dumps(args)], cwd=REPO, stdout=subprocess.PIPE, text=True)
    lines: list[str] = []
    first = threading.Event()

    def read() -> None:
        assert proc.stdout is not None
        for line in proc.stdout:
            lines.append(line)
            first.set()

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    if after_report:
        assert first.wait(timeout=300), "no episode finished"
        time.sleep(rng.uniform(0.0, 1.5))
    else:
        time.sleep(rng.uniform(0.2, 5.0))
    assert proc.poll() is None, "the recording ended before its kill"
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=60)
    reader.join(timeout=60)
    return [int(line.split()[1]) for line in lines if line.startswith("finished ")]


@pytest.mark.slow
def test_sigkill_at_random_moments_then_resume(tmp_path: Path, project: Path) -> None:
    scene = write_yaml(tmp_path / "scene.yaml", mock_scene(success_after=LENGTHS, n_episodes=ENDLESS))
    out = tmp_path / "ds"
    rng = random.Random(20261121)
    reported: list[int] = []
    log: list[str] = []
    for k in range(KILLS):
        args = {"scene": str(scene), "out": str(out), "n": ENDLESS, "formats": ["lerobot", "mcap"], "resume": k > 0}
        done = run_and_kill(args, rng, after_report=k % 3 != 2)
        # a run continues after everything reported before it: a reported episode is never lost and redone
        assert done == list(range(done[0], done[0] + len(done))) if done else True
        assert not reported or not done or done[0] > reported[-1], (reported, done)
        reported += done
        staged = len(list(out.glob("[!.]*/**/.*.tmp")))
        journal = (out / layout.JOURNAL_PATH).exists()
        if not (out / layout.INFO_PATH).exists():
            assert reported == [], "a reported episode must leave a dataset"
            log.append(f"kill {k}: nothing committed yet")
            continue
        seen = verify_mock_dataset(out, "pyav", uncounted_rows_ok=True)  # lerobot on the killed dataset
        assert len(seen["lengths"]) >= len(reported), (seen["lengths"], reported)
        assert seen["lengths"] == expected(len(seen["lengths"]))
        assert len(finished_bags(out / "mcap")) >= len(reported)
        log.append(
            f"kill {k}: run reported {len(done)}, lerobot loads {len(seen['lengths'])} episodes, "
            f"staged files {staged}, journal {journal}"
        )
    print("\n".join(log))
    assert len(reported) >= KILLS // 2, reported
    total = len(reported) + 3
    final = subprocess.run(
        [*DRIVER, json.dumps({"scene": str(scene), "out": str(out), "n": total, "resume": True})],
        cwd=REPO,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert final.returncode == 0, final.stderr
    seen = verify_mock_dataset(out, "pyav")
    assert seen["lengths"] == expected(total)
    assert [b.name for b in finished_bags(out / "mcap")] == [f"episode_{i:06d}" for i in range(total)]
    assert check(out) == []
