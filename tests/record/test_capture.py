"""Real-time capture: a camera encoder that cannot keep up spills frames to disk instead of stalling the fixed-rate
loop; every frame the loop handed over is in the dataset, in order, and the spills are reported."""

from __future__ import annotations

from itertools import pairwise
from pathlib import Path

import av
import numpy as np
import numpy.typing as npt
import pytest

from openral_data.formats.lerobot_v3 import VideoSettings, WriterConfig
from openral_data.formats.lerobot_v3.video import ENCODE_DELAY_ENV
from openral_data.metrics.capture import capture_rows
from openral_data.metrics.sources import open_dataset
from openral_data.producers.hal.session.operator import ScriptedOperator
from openral_data.record.hal_loop import EpisodeEnd
from openral_data.runtime import registry
from openral_data.types import CameraShape
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


def test_a_slow_encoder_spills_while_the_loop_stays_on_time(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The encoder is throttled (0.1 s a frame, half the 20 fps loop's rate) behind a two-frame queue: without
    spilling the loop would wait on it every tick; with it, the loop keeps its deadlines, the frames beyond the
    queue spill and are encoded behind, and the video holds every handed-over sample in order (the repeats the
    report counts, no sample lost or reordered); the episode's record and `stats`' `capture` table say so."""
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
