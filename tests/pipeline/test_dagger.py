"""The DAgger round (#51): a policy drives, the scene's scripted expert is the person who takes over through the
teleop path (`--teleop expert`: its rule presses the takeover button the loop reads at the start of a tick, as a
gamepad's), the frames it drove are marked as a person's, `stats` gives each round's intervention rate, and the
campaign (demos -> train -> DAgger round -> merge) resumes after a SIGKILL in the middle of the round."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from openral_data.columns import INTERVENTION, POLICY_ACTION
from openral_data.errors import ConfigError, DatasetError
from openral_data.metrics.command import StatsOptions, run_stats
from openral_data.producers.hal.teleop.declare import TakeoverRule
from openral_data.record.hal import HalRecordOptions, record_hal
from tests.support.cli import run_cli
from tests.support.hal import episode_infos, frames_table
from tests.support.home import REPO
from tests.support.scenes import write_yaml
from tests.support.teleop_push import expert_proposals
from tests.support.timing import TIMED

pytestmark = TIMED


def _rounds(path: Path) -> list[dict[str, object]]:
    report = json.loads(run_stats(StatsOptions([str(path)], None, None, "json")))
    return list(report["intervention_rounds"])


def test_the_expert_takes_over_by_its_rule_through_the_takeover_button(tmp_path: Path) -> None:
    # random-mock drives, zero-mock is the expert; threshold 0: the policy always departs from it. The rule presses
    # after 2 departing ticks (frames 0, 1), the press is read at the start of the next tick: frame 2 is the
    # expert's; it hands back after 3 frames; then again.
    out = tmp_path / "round"
    rule = TakeoverRule(threshold=0.0, patience=2, hold=3)
    opts = HalRecordOptions(robot="mock_arm", rskill="random-mock", scene="mock_pick", teleop="expert", takeover=True,
                            expert="zero-mock", takeover_rule=rule, max_steps=12, out=out, codec="h264")  # fmt: skip
    summary = record_hal(opts)
    assert summary.frames == 12
    table = frames_table(out)
    marks = table[INTERVENTION]
    assert marks == [False, False, True, True, True, False, False, True, True, True, False, False]
    (info,) = episode_infos(out)
    assert info["operator"] == "policy:random-mock+teleop:expert"
    # the policy is stepped every frame: its proposals are random-mock's (nonzero), whoever drove
    proposals = np.asarray(table[POLICY_ACTION])
    assert np.all(np.abs(proposals).sum(axis=1) > 0)
    (row,) = _rounds(out)  # one round: 6 of 12 frames taken over, 2 takeovers, its one episode
    assert (row["frames"], row["intervention_frames"], row["interventions"]) == (12, 6, 2)
    assert (row["episodes"], row["episodes_taken_over"], row["rate"]) == (1, 1, 0.5)


def test_a_resumed_round_keeps_its_expert_and_takeover_rule(tmp_path: Path) -> None:
    # the round is continued without naming the expert or the rule again: its second episode is corrected by the
    # recorded ones (zero-mock; threshold 0, patience 2, hold 3), not by the defaults (the scene's rSkill; 0.25,
    # 3, 20), so its marks are the first episode's; a rule given again that differs is refused in one line
    out = tmp_path / "round"
    first = HalRecordOptions(robot="mock_arm", rskill="random-mock", scene="mock_pick", teleop="expert", takeover=True,
                             expert="zero-mock", takeover_rule=TakeoverRule(0.0, 2, 3), max_steps=12, out=out,
                             codec="h264")  # fmt: skip
    record_hal(first)
    again = HalRecordOptions(robot="mock_arm", rskill="random-mock", scene="mock_pick", teleop="expert", takeover=True,
                             out=out, n_episodes=2, resume=True, explicit=frozenset({"n_episodes"}))  # fmt: skip
    assert record_hal(again).frames == 12
    table = frames_table(out)
    marks = np.asarray(table[INTERVENTION]).reshape(2, 12)
    assert (
        marks[1].tolist()
        == marks[0].tolist()
        == [False, False, True, True, True, False, False] + [True] * 3 + [False] * 2
    )
    rows = pq.read_table(sorted((out / "data").rglob("*.parquet"))[0]).num_rows
    hold = HalRecordOptions(robot="mock_arm", rskill="random-mock", scene="mock_pick", teleop="expert", takeover=True,
                            takeover_rule=TakeoverRule(0.0, 2, 5), out=out, n_episodes=3, resume=True,
                            explicit=frozenset({"n_episodes", "takeover_hold"}))  # fmt: skip
    with pytest.raises(ConfigError) as refused:
        record_hal(hold)
    assert str(refused.value).endswith(
        "expert.hold: the round was recorded with 3; --takeover-hold 5 differs (leave the option out to continue "
        "with the recorded one)"
    )
    assert pq.read_table(sorted((out / "data").rglob("*.parquet"))[0]).num_rows == rows == 24
    settings = out / ".openral" / "record.json"  # dataset content: a rule written into it is checked as an option
    doc = json.loads(settings.read_text())
    doc["options"]["expert"]["patience"] = -1
    settings.write_text(json.dumps(doc))
    with pytest.raises(DatasetError, match=r"record\.json: expert\.patience: -1: not a whole number in 1\.\.1000000$"):
        record_hal(replace(hold, takeover_rule=TakeoverRule(), explicit=frozenset({"n_episodes"})))


def _kill_mid_round(spec: Path, workdir: Path) -> None:
    """`pipeline run` until the DAgger round's staged dataset has its first frames written, then SIGKILL it all."""
    cmd = [sys.executable, "-m", "openral_data.cli", "pipeline", "run", str(spec), "--workdir", str(workdir)]
    proc = subprocess.Popen(cmd, cwd=REPO, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 900
    while not any((workdir / "corrected").glob(".dagger--*.partial-*/data/*/*")) and proc.poll() is None:
        assert time.monotonic() < deadline, "the DAgger round wrote nothing within 900 s"
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == -signal.SIGKILL, err.decode()[-2000:]


@pytest.mark.slow
def test_campaign_with_a_dagger_round_resumes_after_a_kill_mid_round(project: Path, tmp_path: Path) -> None:
    write_yaml(tmp_path / "small.yaml", {**_small_scene()})
    rule = {"threshold": 0.0, "patience": 2, "hold": 5}
    spec = write_yaml(tmp_path / "p.yaml", {"name": "t", "steps": [
        {"id": "demos", "record": {"scenes": ["small.yaml"], "rskills": ["scripted-push"], "seeds": {"count": 2},
                                   "max_steps": 20, "codec": "h264"}},
        {"id": "policy", "train": {"dataset": "demos", "steps": 2, "batch_size": 2, "save_freq": 2, "chunk_size": 5,
                                   "dim_model": 32, "n_encoder_layers": 1}},
        {"id": "corrected", "dagger": {"policy": "policy", "scene": "small.yaml", "seeds": {"start": 100, "count": 2},
                                       "max_steps": 16, **rule}},
        {"id": "all", "merge": {"inputs": ["demos", "corrected"], "order": "seed", "common": True}},
        {"id": "metrics", "stats": {"inputs": ["corrected"]}}]})  # fmt: skip
    workdir = tmp_path / "run"
    _kill_mid_round(spec, workdir)
    assert not (workdir / "corrected" / "dagger--policy--small--scripted-push").exists()
    res = run_cli("pipeline", "run", str(spec), "--workdir", str(workdir))
    assert res.returncode == 0, res.stderr
    steps = {s["step"]: s["status"] for s in json.loads((workdir / "report.json").read_text())["steps"]}
    assert steps == {"demos": "skipped", "policy": "skipped", "corrected": "ran", "all": "ran", "metrics": "ran"}
    assert not list((workdir / "corrected").glob(".*partial*"))  # the killed round's staging is gone

    # the round redone once: its two seeds, each once; the expert drove from frame 2 for 5 frames, and again
    out = workdir / "corrected" / "dagger--policy--small--scripted-push"
    table = frames_table(out)
    episodes = np.asarray(table["episode_index"])
    marks = np.asarray(table[INTERVENTION])
    assert [i["operator"] for i in episode_infos(out)] == ["policy:small--scripted-push+teleop:expert"] * 2
    pattern = [False, False, *[True] * 5, False, False, *[True] * 5, False, False]
    assert marks[episodes == 0].tolist() == pattern == marks[episodes == 1].tolist()
    actions = np.asarray(table["action"], dtype=np.float32)
    proposals = np.asarray(table[POLICY_ACTION], dtype=np.float32)
    for ep, seed in ((0, 100), (1, 101)):  # the expert's own action on its frames, the policy's on the others
        on = episodes == ep
        expert = expert_proposals(actions[on], seed, scene=str(tmp_path / "small.yaml"))
        np.testing.assert_array_equal(actions[on][marks[on]], expert[marks[on]])
        np.testing.assert_array_equal(actions[on][~marks[on]], proposals[on][~marks[on]])
        assert not np.array_equal(actions[on][marks[on]], proposals[on][marks[on]])
    _lerobot_loads_exactly(out)

    (row,) = json.loads((workdir / "metrics" / "report" / "stats.json").read_text())["intervention_rounds"]
    assert row["dataset"] == out.name and (row["frames"], row["intervention_frames"]) == (32, int(marks.sum()))
    assert (row["interventions"], row["episodes_taken_over"], row["rate"]) == (4, 2, marks.sum() / 32)
    merged = json.loads((workdir / "all" / "dataset" / "meta" / "info.json").read_text())
    assert (merged["total_episodes"], merged["total_frames"]) == (4, 40 + 32)
    assert INTERVENTION not in merged["features"] and POLICY_ACTION not in merged["features"]


def _small_scene() -> dict[str, object]:
    import yaml

    return dict(yaml.safe_load((REPO / "pipelines/scenes/tabletop_push_small.yaml").read_text()))


def _lerobot_loads_exactly(out: Path) -> None:
    """lerobot's LeRobotDataset reads the round frame for frame: the same actions and intervention marks."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/dagger", root=out, video_backend="pyav")
    assert len(ds) == 32 and ds.num_episodes == 2
    data = pq.read_table(next((out / "data").rglob("*.parquet")))
    for i in (0, 2, 9, 31):
        item = ds[i]
        np.testing.assert_array_equal(item["action"].numpy(), np.asarray(data.column("action")[i].as_py(), np.float32))
        assert bool(item[INTERVENTION].item()) is data.column(INTERVENTION)[i].as_py()
