"""`convert` outcomes: what a bag does not say stays unknown (no reward / success columns, `openral.success`
NULL, `stats` reports success as unknown); mapped reward / success topics land in next.reward / next.success;
our own bags and LeRobot v3 -> MCAP -> LeRobot v3 round-trip reward, done and success exactly."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from openral_data.formats.lerobot_v3.reader import read_episodes
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from tests.support.bags import BASE, MAPPING, MS, TYPES, build, samples, write_ros2
from tests.support.cli import run_cli
from tests.support.scenes import mock_scene, write_yaml

OUTCOMES = ("next.reward", "next.done", "next.success")


def _load(root: Path) -> Any:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    return LeRobotDataset("local/check", root=root, video_backend="pyav")


def _frames(root: Path) -> pa.Table:
    return pq.read_table(root / "data").sort_by("index")


def _convert(bag: Path, out: Path, mapping: Path) -> subprocess.CompletedProcess[str]:
    return run_cli("convert", str(bag), str(out), "--mapping", str(mapping), "--codec", "h264")


def _overview(root: Path) -> dict[str, Any]:
    """The `stats` groups row of the one dataset, from the real CLI's JSON output."""
    proc = run_cli("stats", str(root), "--format", "json")
    assert proc.returncode == 0, proc.stderr
    groups = json.loads(proc.stdout)["groups"]
    assert len(groups) == 1, groups
    return groups[0]  # type: ignore[no-any-return]


def test_log_without_outcomes_claims_none(tmp_path: Path) -> None:
    bag = write_ros2(tmp_path / "log", "mcap", duration_ms=1000)
    out = tmp_path / "ds"
    proc = _convert(bag, out, write_yaml(tmp_path / "m.yaml", MAPPING))
    assert proc.returncode == 0, proc.stderr
    assert "no reward" in proc.stdout and "success unknown" in proc.stdout
    info = json.loads((out / "meta" / "info.json").read_text())
    assert "next.reward" not in info["features"] and "next.success" not in info["features"]
    assert info["features"]["next.done"]["dtype"] == "bool"
    frames = _frames(out)
    assert "next.reward" not in frames.column_names and "next.success" not in frames.column_names
    assert frames.column("next.done").to_pylist() == [False] * 9 + [True]
    assert read_episodes(out).column("openral.success").to_pylist() == [None]
    ds = _load(out)  # lerobot 0.6.1 loads a dataset without outcome columns
    assert len(ds) == 10 and "next.reward" not in ds[0] and bool(ds[9]["next.done"])
    row = _overview(out)
    assert row["episodes"] == 1 and row["success_known"] == 0
    assert row["success_rate"] is None and row["ci95_low"] is None and row["successes"] is None
    # the table form says it in words, never as 0 %
    proc = run_cli("stats", str(out))
    assert proc.returncode == 0, proc.stderr
    assert "0.0%" not in proc.stdout and "0 %" not in proc.stdout


# reward: std_msgs/Float32 at 20 Hz, value 0.25 * k; success: std_msgs/Bool, False at 0 ms, True from 1500 ms
def _write_outcome_bag(
    path: Path, duration_ms: int = 2000, success: tuple[tuple[int, bool], ...] = ((0, False), (1500, True))
) -> Path:
    store = get_typestore(Stores.ROS2_HUMBLE)
    t = store.types
    with Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as writer:
        conns = {topic: writer.add_connection(topic, msgtype, typestore=store) for topic, msgtype in TYPES.items()}
        c_reward = writer.add_connection("/reward", "std_msgs/msg/Float32", typestore=store)
        c_success = writer.add_connection("/task_success", "std_msgs/msg/Bool", typestore=store)
        extra: list[tuple[int, Any, Any, str]] = []
        for k, ms in enumerate(range(0, duration_ms, 50)):
            extra.append((BASE + ms * MS, c_reward, t["std_msgs/msg/Float32"](data=0.25 * k), "std_msgs/msg/Float32"))
        for ms, value in [(ms, v) for ms, v in success if ms < duration_ms]:
            extra.append((BASE + ms * MS, c_success, t["std_msgs/msg/Bool"](data=value), "std_msgs/msg/Bool"))
        rows = [
            (ns, conns[topic], build(store, topic, ns, f, False), TYPES[topic]) for topic, ns, f in samples(duration_ms)
        ]
        for ns, conn, msg, msgtype in sorted(rows + extra, key=lambda r: r[0]):
            writer.write(conn, ns, store.serialize_cdr(msg, msgtype))
    return path


def test_mapped_reward_and_success_topics(tmp_path: Path) -> None:
    bag = _write_outcome_bag(tmp_path / "log")
    mapping = {**MAPPING, "reward": {"topic": "/reward"}, "success": {"topic": "/task_success", "field": "data"}}
    out = tmp_path / "ds"
    proc = _convert(bag, out, write_yaml(tmp_path / "m.yaml", mapping))
    assert proc.returncode == 0, proc.stderr
    assert "reward from /reward" in proc.stdout and "success from /task_success" in proc.stdout
    assert "mapped /reward" in proc.stdout
    frames = _frames(out)
    t_ms = [100 * i for i in range(20)]
    assert frames.column("next.reward").to_pylist() == [0.25 * (t // 50) for t in t_ms]  # previous sample
    assert frames.column("next.success").to_pylist() == [t >= 1500 for t in t_ms]
    assert frames.column("next.done").to_pylist() == [False] * 19 + [True]
    assert read_episodes(out).column("openral.success").to_pylist() == [True]
    ds = _load(out)
    assert float(ds[19]["next.reward"]) == 0.25 * 38 and bool(ds[19]["next.success"])
    row = _overview(out)
    assert row["success_known"] == 1 and row["successes"] == 1 and row["success_rate"] == 1.0


def test_success_topic_at_the_last_frame_decides_the_episode(tmp_path: Path) -> None:
    bag = _write_outcome_bag(tmp_path / "log", duration_ms=1000)  # ends before the True at 1500 ms
    mapping = {**MAPPING, "success": {"topic": "/task_success"}}
    out = tmp_path / "ds"
    proc = _convert(bag, out, write_yaml(tmp_path / "m.yaml", mapping))
    assert proc.returncode == 0, proc.stderr
    # the only message (False at 0 ms) is known: the episode failed, it is not unknown
    assert read_episodes(out).column("openral.success").to_pylist() == [False]
    assert "next.reward" not in _frames(out).column_names


def test_episode_without_a_success_message_is_unknown(tmp_path: Path) -> None:
    """Two bags, one episode each: the first says nothing on the success topic, the second says True."""
    src = tmp_path / "logs"
    src.mkdir()
    _write_outcome_bag(src / "a", duration_ms=1000, success=())
    _write_outcome_bag(src / "b", duration_ms=2000)
    mapping = {**MAPPING, "success": {"topic": "/task_success"}}
    out = tmp_path / "ds"
    proc = _convert(src, out, write_yaml(tmp_path / "m.yaml", mapping))
    assert proc.returncode == 0, proc.stderr
    assert read_episodes(out).column("openral.success").to_pylist() == [None, True]
    frames = _frames(out)
    assert frames.column("next.success").to_pylist()[:10] == [False] * 10  # never carried over from elsewhere
    row = _overview(out)
    assert (row["episodes"], row["success_known"], row["successes"], row["success_rate"]) == (2, 1, 1, 1.0)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"success": {"field": "data"}}, "success needs a topic, marker: true, or both"),
        ({"success": {"marker": True}}, "marker: true needs episodes.marker_topic"),
        # roles may share a topic, each reading its own field: this one is not a number
        ({"reward": {"topic": "/cmd"}}, "b: mapping: reward (/cmd.data): field is ndarray, not a number"),
        ({"success": {"topic": "/task"}}, "success.topic /task is also the task_topic"),
        ({"align": {"clock": "wall"}}, "align.clock"),
        (
            {"success": {"topic": "/ep"}, "episodes": {"split": "marker", "marker_topic": "/ep"}},
            "success.topic /ep is the marker_topic",
        ),
    ],
)
def test_outcome_mapping_errors(tmp_path: Path, change: dict[str, Any], message: str) -> None:
    bag = write_ros2(tmp_path / "b", "mcap", duration_ms=300)
    mapping = write_yaml(tmp_path / "m.yaml", {**MAPPING, **change})
    proc = _convert(bag, tmp_path / "ds", mapping)
    assert proc.returncode == 2, proc.stdout
    assert message in proc.stderr and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert not (tmp_path / "ds").exists()


def test_success_field_that_is_not_a_bool_is_one_line(tmp_path: Path) -> None:
    bag = _write_outcome_bag(tmp_path / "log", duration_ms=500)
    mapping = {**MAPPING, "success": {"topic": "/reward"}}
    proc = run_cli(
        "convert", str(bag), str(tmp_path / "ds"), "--mapping", str(write_yaml(tmp_path / "m.yaml", mapping))
    )
    assert proc.returncode == 2
    assert "success (/reward.data): field is float, not a bool" in proc.stderr, proc.stderr


def _scene(tmp_path: Path) -> Path:
    # episode 1 never succeeds and is cut at max_steps: done without success
    return write_yaml(tmp_path / "s.yaml", mock_scene(success_after=[6, 60, 4], max_steps=10, n_episodes=3))


def _outcomes(root: Path) -> dict[str, list[Any]]:
    frames = _frames(root)
    got = {k: frames.column(k).to_pylist() for k in (*OUTCOMES, "episode_index", "frame_index")}
    got["openral.success"] = read_episodes(root).column("openral.success").to_pylist()
    return got


def test_record_mcap_convert_round_trips_outcomes(project: Path, tmp_path: Path) -> None:
    """One recording written as LeRobot v3 and as MCAP: the MCAP converted back equals the direct dataset."""
    rec = tmp_path / "rec"
    record(RecordOptions(scene=str(_scene(tmp_path)), out=rec, formats=("lerobot", "mcap"), image_format="png"))
    direct = _outcomes(rec)
    assert direct["openral.success"] == [True, False, True]
    assert sum(direct["next.reward"]) == 2.0 and sum(direct["next.done"]) == 3
    out = tmp_path / "ds"
    proc = run_cli("convert", str(rec / "mcap"), str(out), "--codec", "h264")
    assert proc.returncode == 0, proc.stderr
    assert "reward from /reward" in proc.stdout and "success from end markers" in proc.stdout
    assert _outcomes(out) == direct


def test_lerobot_mcap_lerobot_round_trips_outcomes(project: Path, tmp_path: Path) -> None:
    ds = tmp_path / "ds"
    record(RecordOptions(scene=str(_scene(tmp_path)), out=ds, codec="h264"))
    bags, back = tmp_path / "bags", tmp_path / "back"
    assert run_cli("convert", str(ds), str(bags), "--image-format", "png").returncode == 0
    proc = run_cli("convert", str(bags), str(back), "--codec", "h264")
    assert proc.returncode == 0, proc.stderr
    assert _outcomes(back) == _outcomes(ds)


def test_unknown_outcomes_stay_unknown_through_mcap(tmp_path: Path) -> None:
    """A converted hardware log (no reward, success unknown) -> MCAP -> LeRobot v3 still claims nothing."""
    bag = write_ros2(tmp_path / "log", "mcap", duration_ms=1000)
    ds, bags, back = tmp_path / "ds", tmp_path / "bags", tmp_path / "back"
    mapping = write_yaml(tmp_path / "m.yaml", MAPPING)
    assert _convert(bag, ds, mapping).returncode == 0
    proc = run_cli("convert", str(ds), str(bags), "--image-format", "png")
    assert proc.returncode == 0, proc.stderr
    from tests.support.mcap import check_bag

    topics = check_bag(bags / "episode_000000")
    assert "/reward" not in topics
    end = json.loads(topics["/openral/episode"][-1][1].data)
    assert end["event"] == "end" and end["success"] is None
    proc = run_cli("convert", str(bags), str(back), "--codec", "h264")
    assert proc.returncode == 0, proc.stderr
    features = json.loads((back / "meta" / "info.json").read_text())["features"]
    assert "next.reward" not in features and "next.success" not in features
    assert read_episodes(back).column("openral.success").to_pylist() == [None]
    assert _frames(back).column("next.done").to_pylist() == _frames(ds).column("next.done").to_pylist()
    assert np.array_equal(
        np.stack(_frames(back).column("observation.state").to_pylist()),
        np.stack(_frames(ds).column("observation.state").to_pylist()),
    )
