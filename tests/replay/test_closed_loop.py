"""`replay --mode closed-loop --instruction/--device`: the policy is given the instruction (and a re-recording
records it as every frame's task); the options are refused where they mean nothing."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from openral_data.errors import UsageError
from openral_data.replay import ReplayOptions, replay
from openral_data.runtime import registry
from tests.support.policies import listening
from tests.support.replay import record_mock


def test_closed_loop_gives_the_policy_the_instruction_and_records_it(
    project: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    dataset = record_mock(project, tmp_path / "mock").out
    seen: list[str] = []

    monkeypatch.setitem(registry.POLICIES, "zero", listening(seen))
    again = tmp_path / "again"
    opts = ReplayOptions(dataset, mode="closed-loop", rskill="zero-mock", out=tmp_path / "res", episodes="0")
    replay(dataclasses.replace(opts, instruction="wave", record=again, codec="h264"))
    assert seen and set(seen) == {"wave"}
    ds = LeRobotDataset("local/again", root=again, video_backend="pyav")
    assert len(ds) == len(seen) and {ds[i]["task"] for i in range(len(ds))} == {"wave"}
    seen.clear()
    replay(dataclasses.replace(opts, out=tmp_path / "res2", device="cpu"))
    assert seen and set(seen) == {"pick up the mock cube"}  # the scene's, without --instruction

    with pytest.raises(UsageError, match=r"^--instruction: only with --mode closed-loop"):
        replay(ReplayOptions(dataset, mode="actions", instruction="x", out=tmp_path / "r3"))
    with pytest.raises(UsageError, match=r"^--device: --mode actions runs no policy"):
        replay(ReplayOptions(dataset, mode="actions", device="cpu", out=tmp_path / "r4"))
