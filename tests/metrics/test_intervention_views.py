"""Interventions in `stats`: the `interventions` / `intervention_episodes` views and the report's tables, on
datasets written through the bridge and our writer with the intervention columns (as `record` writes them),
checked against numbers counted here by hand; lerobot 0.6.1 loads such a dataset; a dataset without the
columns (a plain recording, a lerobot-written one) adds no rows and no tables."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from openral_data.columns import INTERVENTION, POLICY_ACTION
from openral_data.formats.lerobot_v3 import LeRobotV3Writer, WriterConfig
from openral_data.metrics.command import StatsOptions, run_stats, stats_query
from openral_data.policies.intervention import intervention_columns
from openral_data.runtime.bridge import DatasetBridge
from openral_data.types import DatasetSchema, Observation
from tests.support.lerobot_written import write_lerobot_dataset

ACTIONS = ("dx", "dy", "gripper")
# per dataset: (policy, per episode the flags of its frames)
FLAGS: dict[str, tuple[str, list[str]]] = {
    "ds_a": ("scripted-push", ["0011100110", "0000", "1111100"]),
    "ds_b": ("other-policy", ["0100000", "00110011100"]),
}


def _proposal(e: int, t: int) -> np.ndarray[Any, np.dtype[np.float32]]:
    return np.array([0.01 * t, -0.02 * e, 1.0], dtype=np.float32)


def _write(root: Path, policy: str, episodes: list[str]) -> None:
    schema = DatasetSchema(
        fps=10,
        state_names=("x", "y"),
        action_names=ACTIONS,
        cameras={},
        robot_type="bot",
        frame_columns=intervention_columns(ACTIONS),
    )
    bridge = DatasetBridge(schema, [LeRobotV3Writer(root, schema, WriterConfig())])
    try:
        for e, flags in enumerate(episodes):
            bridge.begin_episode(e, {})
            for t, flag in enumerate(flags):
                proposal = _proposal(e, t)
                action = proposal + np.float32(0.5) if flag == "1" else proposal
                obs = Observation({}, np.array([t, e], dtype=np.float32), "push", time=t / 10)
                columns = {POLICY_ACTION: proposal, INTERVENTION: flag == "1"}
                bridge.add_step(obs, action, reward=0.0, done=t == len(flags) - 1, success=False, columns=columns)
            bridge.end_episode(False, info={"operator": f"policy:{policy}+teleop:keyboard"})
    finally:
        bridge.close()


def _runs(flags: str) -> list[tuple[int, int]]:
    """[start, end) of each run of 1s, counted by hand."""
    out, start = [], None
    for t, f in enumerate(flags + "0"):
        if f == "1" and start is None:
            start = t
        elif f == "0" and start is not None:
            out.append((start, t))
            start = None
    return out


@pytest.fixture(scope="module")
def sessions(tmp_path_factory: pytest.TempPathFactory) -> Path:
    base = tmp_path_factory.mktemp("interventions")
    for name, (policy, episodes) in FLAGS.items():
        _write(base / name, policy, episodes)
    return base


def test_the_views_list_every_takeover_and_each_episodes_rate(sessions: Path) -> None:
    paths = [sessions / n for n in FLAGS]
    runs = stats_query(paths, "SELECT * FROM interventions ORDER BY dataset, episode_index, start_frame").records()
    want = [
        {"dataset": n, "episode_index": e, "start_frame": s, "end_frame": end, "length": end - s}
        for n, (_, eps) in FLAGS.items()
        for e, flags in enumerate(eps)
        for s, end in _runs(flags)
    ]
    assert runs == want

    got = stats_query(paths, "SELECT * FROM intervention_episodes ORDER BY dataset, episode_index").records()
    expected = []
    for n, (policy, eps) in FLAGS.items():
        for e, flags in enumerate(eps):
            lengths = [end - s for s, end in _runs(flags)]
            expected.append(
                {
                    "dataset": n, "episode_index": e, "policy": policy, "frames": len(flags),
                    "intervention_frames": flags.count("1"), "rate": flags.count("1") / len(flags),
                    "interventions": len(lengths), "mean_length": float(np.mean(lengths)) if lengths else None,
                    "max_length": max(lengths) if lengths else None,
                }
            )  # fmt: skip
    assert got == expected


def test_the_report_has_intervention_tables_per_episode_and_per_policy(sessions: Path) -> None:
    report = json.loads(run_stats(StatsOptions([str(sessions / n) for n in FLAGS], fmt="json")))
    per_episode = report["interventions"]
    assert [(r["dataset"], r["episode_index"], r["interventions"]) for r in per_episode] == [
        ("ds_a", 0, 2), ("ds_a", 1, 0), ("ds_a", 2, 1), ("ds_b", 0, 1), ("ds_b", 1, 2),
    ]  # fmt: skip
    assert per_episode[0]["rate"] == pytest.approx(5 / 10) and per_episode[0]["max_length"] == 3
    policies = {r["policy"]: r for r in report["intervention_policies"]}
    a = policies["scripted-push"]
    assert (a["episodes"], a["frames"], a["intervention_frames"], a["interventions"]) == (3, 21, 10, 3)
    assert a["rate"] == pytest.approx(10 / 21) and a["mean_length"] == pytest.approx(10 / 3) and a["max_length"] == 5
    b = policies["other-policy"]
    assert (b["frames"], b["intervention_frames"], b["interventions"], b["max_length"]) == (18, 6, 3, 3)


@pytest.mark.slow  # lerobot (torch) import: ~10 s
def test_lerobot_loads_the_intervention_columns(sessions: Path) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/check", root=sessions / "ds_a", video_backend="pyav")
    assert ds.meta.features[POLICY_ACTION]["names"] == list(ACTIONS)
    flags = FLAGS["ds_a"][1]
    starts = np.cumsum([0, *(len(f) for f in flags)])
    for e, f in enumerate(flags):
        for t, flag in enumerate(f):
            item = ds[int(starts[e]) + t]
            assert bool(item[INTERVENTION]) is (flag == "1")
            assert np.array_equal(item[POLICY_ACTION].numpy(), _proposal(e, t))
            assert np.allclose(item["action"].numpy(), _proposal(e, t) + (0.5 if flag == "1" else 0.0))


def test_a_dataset_without_the_columns_has_empty_views_and_no_tables(sessions: Path, tmp_path: Path) -> None:
    foreign = tmp_path / "lerobot"
    write_lerobot_dataset(foreign, with_success=True)
    for view in ("interventions", "intervention_episodes"):
        assert stats_query([foreign], f"SELECT count(*) AS n FROM {view}").records() == [{"n": 0}]
    report = json.loads(run_stats(StatsOptions([str(foreign)], fmt="json")))
    assert "interventions" not in report and "intervention_policies" not in report
    # beside a session: only the session's episodes
    mixed = stats_query([foreign, sessions / "ds_a"], "SELECT DISTINCT dataset FROM intervention_episodes")
    assert mixed.records() == [{"dataset": "ds_a"}]
