"""Real-time capture: a camera encoder that cannot keep up spills frames to disk instead of stalling the fixed-rate
loop; every frame the loop handed over is in the dataset, in order, and the spills are reported."""

from __future__ import annotations

import json
import logging
import os
import signal
import subprocess
import sys
import time
from itertools import pairwise
from pathlib import Path

import av
import numpy as np
import numpy.typing as npt
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from openral_data.formats.lerobot_v3 import VideoSettings, WriterConfig
from openral_data.formats.lerobot_v3.video import ENCODE_DELAY_ENV
from openral_data.metrics.capture import capture_rows
from openral_data.metrics.sources import open_dataset
from openral_data.producers.hal.session.operator import ScriptedOperator
from openral_data.record.hal_loop import EpisodeEnd
from openral_data.runtime import registry
from openral_data.types import CameraShape
from tests.support.cli import run_cli
from tests.support.hal import SlowCamera, episode_infos, run_loop, ur5e_twin
from tests.support.timing import TIMED

pytestmark = TIMED


class NumberedCamera(SlowCamera):
    """Sample k is solid (10 (k mod 26), 10 (k // 26 mod 26), 0): its number survives a lossy codec."""

    def _capture(self) -> npt.NDArray[np.uint8]:
        img = super()._capture()
        k = self.count - 1
        img[..., 1] = 10 * (k // 26 % 26)
        img[..., 2] = 0
        return img


def _sample_numbers(video: Path) -> list[int]:
    with av.open(str(video)) as container:
        pixels = [f.to_ndarray(format="rgb24").reshape(-1, 3).mean(axis=0) for f in container.decode(video=0)]
    return [round(p[0] / 10) + 26 * round(p[1] / 10) for p in pixels]


def test_a_slow_encoder_spills_while_the_loop_stays_on_time(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """The encoder is throttled (0.1 s a frame, half the 20 fps loop's rate) behind a two-frame queue: without
    spilling the loop would wait on it every tick; with it, the loop keeps its deadlines, the frames beyond the
    queue spill and are encoded behind, and the video holds every handed-over sample in order (the repeats the
    report counts, no sample lost or reordered); the episode's record and `stats`' `capture` table say so, and
    the operator was warned once, as the first frame spilled."""
    caplog.set_level(logging.WARNING, logger="openral_data")
    monkeypatch.setenv(ENCODE_DELAY_ENV, "0.1")
    hal = ur5e_twin(cameras=[])
    hal.cameras["cam"] = NumberedCamera("cam", period=0.03, shape=CameraShape(32, 32))
    rskill, path = registry.resolve_rskill("sweep-ur5e")
    policy = registry.policy_factory(rskill, str(path))(rskill)
    out = tmp_path / "ds"
    writer = WriterConfig(video=VideoSettings(codec="h264"), queue_size=2, spill=True)
    [(end, rep)] = run_loop(hal, policy, ScriptedOperator(), out, fps=20, max_steps=40, writer=writer)  # type: ignore[arg-type]
    assert end is EpisodeEnd.KEPT and rep.frames == 40 and rep.accounted(), rep
    assert rep.overruns <= 8, rep  # waiting on the encoder would make nearly every one of the 40 ticks late
    numbers = _sample_numbers(next((out / "videos").rglob("*.mp4")))
    assert len(numbers) == 40 and all(b >= a for a, b in pairwise(numbers)), numbers
    assert sum(a == b for a, b in pairwise(numbers)) == rep.repeated["cam"], numbers
    [info] = episode_infos(out)
    spilled = info["capture"]["cam"]["spilled"]
    assert 15 <= spilled <= 38, info["capture"]  # about half the frames: the encoder runs at half the rate
    assert info["capture"]["cam"]["encoder_lag_s"] >= 0.1 * spilled / 2
    assert 0 < info["hal"]["max_age"]["cam"] <= 0.15
    [row] = capture_rows([open_dataset(out)])
    assert row[1:] == [0, "cam", rep.overruns, spilled, info["hal"]["max_age"]["cam"], row[-1]] and row[-1] > 0
    assert not [p for p in out.rglob("*") if "spill" in p.name]
    said = [r.getMessage() for r in caplog.records if "spill" in r.getMessage()]
    assert len(said) == 1 and said[0].startswith("camera cam: its encoder cannot keep up"), said


@pytest.mark.slow  # a subprocess recording killed mid-spill, then resumed and loaded by lerobot
def test_sigkill_during_a_spill_loses_no_committed_episode_and_resume_finishes(tmp_path: Path, project: Path) -> None:
    """`record --hal` with a throttled encoder is SIGKILLed while frames of the episode in flight are spilled.
    `record --hal --resume` with another robot is refused in one line and changes nothing; with the same one it
    recovers (the spilled frames and the partial video go to the quarantine), keeps every committed episode's rows
    as they were, and records the remaining episode with the recorded settings (40 frames, h264, the next seed);
    lerobot 0.6.1 then loads every frame of every episode and `doctor` finds the dataset clean."""
    out = tmp_path / "ds"
    args = [
        "record", "--hal", "ur5e", "--rskill", "sweep-ur5e", "--fps", "20", "--max-steps", "40",
        "--n-episodes", "1000", "--codec", "h264", "--out", str(out), "-q",
    ]  # fmt: skip
    # the encoder at 2 frames/s: below the loop's rate even on loaded cores, so the 16-frame queue overflows and
    # frames spill in every episode (at 10 frames/s a loaded machine's loop was too slow to spill at all)
    env = {**os.environ, "MUJOCO_GL": "egl", ENCODE_DELAY_ENV: "0.5"}
    proc = subprocess.Popen([sys.executable, "-m", "openral_data.cli", *args], env=env, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 300
        while not ((out / "meta/info.json").is_file() and any(out.rglob(".*.npy.tmp"))):
            assert proc.poll() is None and time.monotonic() < deadline, "no spill after a committed episode"
            time.sleep(0.02)
        proc.send_signal(signal.SIGKILL)
    finally:
        proc.kill()
        proc.wait(timeout=60)
    committed = json.loads((out / "meta/info.json").read_text())["total_episodes"]
    before = _committed_rows(out)
    assert committed >= 1 and len(before) == 40 * committed
    other = run_cli("record", "--hal", "so101", "--resume", "--out", str(out), "-q")
    assert other.returncode == 2 and other.stderr.count("\n") == 1, other.stderr
    assert "record.json: hal: the dataset was recorded with ur5e; --hal so101" in other.stderr
    assert any(out.rglob(".*.npy.tmp"))  # refused before any recovery: nothing touched
    total = str(committed + 1)
    done = run_cli("record", "--hal", "ur5e", "--rskill", "sweep-ur5e", "--resume", "--out", str(out),
                   "--n-episodes", total, "--json")  # fmt: skip
    assert done.returncode == 0, done.stderr
    doc = json.loads(done.stdout)
    assert doc["resumed_at"] == committed and doc["episodes"] == 1 and doc["frames"] == 40, doc
    assert any("staged file(s)" in line for line in doc["recovered"]), doc["recovered"]
    assert _committed_rows(out)[: len(before)] == before  # the committed episodes, untouched
    assert [r["openral.seed"] for r in _episode_rows(out)] == list(range(committed + 1))
    assert any((out / ".openral/quarantine").rglob(".*.npy.tmp"))  # the spilled frames, kept aside
    assert not [p for p in out.rglob("*.tmp") if ".openral" not in p.parts]
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/resumed", root=out, video_backend="pyav")
    assert ds.num_episodes == committed + 1 and len(ds) == 40 * ds.num_episodes
    assert all(ds[i]["observation.images.wrist"].shape[0] == 3 for i in range(len(ds)))  # every frame decodes
    assert ds.meta.info["features"]["observation.images.wrist"]["info"]["video.codec"] == "h264"
    again = run_cli("doctor", str(out))
    assert again.returncode == 0, again.stdout + again.stderr


def _committed_rows(root: Path) -> list[tuple[int, int, list[float]]]:
    """Every data row's (episode, frame, action), in index order."""
    table = pa.concat_tables(pq.read_table(p) for p in sorted((root / "data").rglob("*.parquet"))).sort_by("index")
    return list(
        zip(
            table["episode_index"].to_pylist(),
            table["frame_index"].to_pylist(),
            table["action"].to_pylist(),
            strict=True,
        )
    )


def _episode_rows(root: Path) -> list[dict[str, object]]:
    files = sorted((root / "meta/episodes").rglob("*.parquet"))
    return sorted((r for p in files for r in pq.read_table(p).to_pylist()), key=lambda r: int(r["episode_index"]))
