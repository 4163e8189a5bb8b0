"""A mapping's (or our bags' start marker's) per-frame `columns` cannot take a name that is lerobot's, an episode
column of ours or one of our `openral.*` columns with another dtype (`stats` reads `openral.intervention` as a bool);
`openral.policy_action` has the action's dimension; a column's topic is not the task or marker topic; a folder of our
own bags converts only when every bag carries the same columns; a malformed marker names the field on one line;
`stats` reads a foreign dataset whose `openral.intervention` is not our flag as one without it (issue #32)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from pydantic import ValidationError
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

from openral_data.columns import FRAME_COLUMNS, INTERVENTION, POLICY_ACTION
from openral_data.formats.lerobot_v3 import LeRobotV3Writer, WriterConfig
from openral_data.formats.lerobot_v3.features import DEFAULT_FEATURES, EPISODE_EXTRA_COLUMNS, OUTCOME_FEATURES
from openral_data.formats.mcap import McapSink, finished_bags
from openral_data.metrics.command import stats_query
from openral_data.policies.intervention import intervention_columns
from openral_data.runtime.bridge import DatasetBridge
from openral_data.schemas.mapping import Mapping
from openral_data.types import DatasetSchema, FrameColumn, Observation
from tests.support.bags import MAPPING, write_ros2
from tests.support.inproc import run_inproc
from tests.support.scenes import write_yaml

ACTIONS = ("dx", "dy")


def _mapping(columns: dict[str, Any], **more: Any) -> Mapping:
    return Mapping.model_validate({**MAPPING, "columns": columns, **more})


def test_own_columns_are_the_intervention_sessions() -> None:
    assert {c.key: c.dtype for c in intervention_columns(ACTIONS)} == FRAME_COLUMNS


@pytest.mark.parametrize(
    "key",
    sorted({*DEFAULT_FEATURES, *OUTCOME_FEATURES, *EPISODE_EXTRA_COLUMNS, "task", "observation.images", "openral.x"}),
)
def test_reserved_names_are_refused(key: str) -> None:
    with pytest.raises(ValidationError, match="columns: "):
        _mapping({key: {"topic": "/cmd", "names": ["a", "b"]}})


@pytest.mark.parametrize(("key", "dtype"), [(INTERVENTION, "float32"), (POLICY_ACTION, "bool")])
def test_own_columns_keep_their_dtype(key: str, dtype: str) -> None:
    with pytest.raises(ValidationError, match=f"is a {FRAME_COLUMNS[key]} column"):
        _mapping({key: {"topic": "/cmd", "dtype": dtype}})
    _mapping({key: {"topic": "/cmd", "dtype": FRAME_COLUMNS[key]}})  # its own dtype is fine


@pytest.mark.parametrize("topic", ["/task", "/openral/episode"])
def test_a_column_is_not_on_the_task_or_marker_topic(topic: str) -> None:
    with pytest.raises(ValidationError, match=f"topic {topic} is the task_topic or the marker_topic"):
        _mapping({"my.col": {"topic": topic}}, episodes={"split": "marker", "marker_topic": "/openral/episode"})


def _one_line(done: Any, out: Path) -> str:
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(lines) == 1 and lines[0].startswith("error: "), done.stderr
    assert not out.exists()
    return str(lines[0])


def test_a_proposal_has_the_actions_dimension(tmp_path: Path) -> None:
    bag = write_ros2(tmp_path / "b", "mcap", duration_ms=300)
    columns = {POLICY_ACTION: {"topic": "/joint_states", "field": "position"}}  # 4 values, the action has 2
    mapping = write_yaml(tmp_path / "m.yaml", {**MAPPING, "columns": columns})
    out = tmp_path / "ds"
    done = run_inproc("convert", str(bag), str(out), "--mapping", str(mapping), "--codec", "h264")
    assert "mapping: columns.openral.policy_action: 4 dimensions, the action has 2" in _one_line(done, out)


def _own_bags(root: Path, columns: tuple[FrameColumn, ...], episodes: int = 1) -> list[Path]:
    """Our own bags of `episodes` 3-frame episodes, with the per-frame `columns`."""
    schema = DatasetSchema(
        fps=10, state_names=("x",), action_names=ACTIONS, cameras={}, robot_type="bot", frame_columns=columns
    )
    bridge = DatasetBridge(schema, [McapSink(root, schema)])
    values = {INTERVENTION: True, POLICY_ACTION: np.zeros(2, np.float32)}
    try:
        for e in range(episodes):
            bridge.begin_episode(e, {})
            for t in range(3):
                obs = Observation({}, np.array([t], np.float32), "push", time=t / 10)
                action = np.array([t, e], np.float32)
                row = {c.key: values[c.key] for c in columns}
                bridge.add_step(obs, action, reward=0.0, done=t == 2, success=False, columns=row)
            bridge.end_episode(False)
    finally:
        bridge.close()
    return finished_bags(root)


def test_own_bags_must_carry_the_same_columns(tmp_path: Path) -> None:
    [plain] = _own_bags(tmp_path / "plain", ())
    flagged = _own_bags(tmp_path / "flagged", intervention_columns(ACTIONS), episodes=2)
    both = tmp_path / "both"
    both.mkdir()
    shutil.move(plain, both / "episode_000000")  # a plain bag first: its columns (none) would decide
    for i, bag in enumerate(flagged, 1):
        shutil.move(bag, both / f"episode_{i:06d}")
    out = tmp_path / "ds"
    line = _one_line(run_inproc("convert", str(both), str(out), "--codec", "h264"), out)
    first, other = both / "episode_000000", both / "episode_000001"
    assert line == f"error: {other}: /openral/episode start marker: frame_columns: differ from {first}'s"
    shutil.rmtree(both / "episode_000000")  # the flagged bags alone convert, with their flags
    done = run_inproc("convert", str(both), str(out), "--codec", "h264")
    assert done.returncode == 0, done.stderr
    assert stats_query([out], "SELECT count(*) AS n FROM interventions").records() == [{"n": 2}]


def _marker_bag(path: Path, frame_columns: dict[str, Any]) -> Path:
    """A bag of ours reduced to its topics and its start marker, whose `frame_columns` are these."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    string = "std_msgs/msg/String"
    types = {"/openral/episode": string, "/task": string, "/joint_states": "sensor_msgs/msg/JointState"}
    types |= {"/action": "std_msgs/msg/Float32MultiArray", "/openral/intervention": "std_msgs/msg/Bool"}
    start = {"event": "start", "fps": 10, "state_names": ["x"], "action_names": list(ACTIONS), "cameras": []}
    marker = json.dumps({**start, "frame_columns": frame_columns})
    with Writer2(path, version=8, storage_plugin=StoragePlugin.MCAP) as writer:
        conns = {topic: writer.add_connection(topic, msgtype, typestore=store) for topic, msgtype in types.items()}
        msg = store.types[string](data=marker)
        writer.write(conns["/openral/episode"], 1, store.serialize_cdr(msg, string))
    return path


@pytest.mark.parametrize(
    ("columns", "message"),
    [
        (
            {INTERVENTION: {"topic": "/openral/intervention", "dtype": "float64", "names": []}},
            "frame_columns.'openral.intervention'.dtype: Input should be 'float32' or 'bool'",
        ),
        (
            {INTERVENTION: {"topic": "/openral/intervention", "dtype": "float32", "names": ["a", "b"]}},
            "frame_columns: 'openral.intervention' is a bool column (dtype: bool)",
        ),
        (
            {POLICY_ACTION: {"topic": "/action", "dtype": "float32", "names": ["a", "a"]}},
            "frame_columns.'openral.policy_action': names must be a non-empty list of unique names",
        ),
        (
            {INTERVENTION: {"topic": "/task", "dtype": "bool", "names": []}},
            "frame_columns: 'openral.intervention': topic /task is the task_topic or the marker_topic",
        ),
    ],
)
def test_a_malformed_marker_names_the_field(tmp_path: Path, columns: dict[str, Any], message: str) -> None:
    bag = _marker_bag(tmp_path / "bag", columns)
    out = tmp_path / "ds"
    line = _one_line(run_inproc("convert", str(bag), str(out), "--codec", "h264"), out)
    assert line == f"error: {bag}: /openral/episode start marker: {message}"


def test_stats_reads_a_foreign_intervention_column_as_none(tmp_path: Path) -> None:
    """A dataset (not ours) whose `openral.intervention` is a float32 [2]: no takeovers, the report still runs."""
    root = tmp_path / "foreign"
    column = FrameColumn(INTERVENTION, "float32", ("a", "b"))
    schema = DatasetSchema(
        fps=10, state_names=("x",), action_names=ACTIONS, cameras={}, robot_type="bot", frame_columns=(column,)
    )
    bridge = DatasetBridge(schema, [LeRobotV3Writer(root, schema, WriterConfig())])
    try:
        bridge.begin_episode(0, {})
        for t in range(3):
            obs = Observation({}, np.array([t], np.float32), "push", time=t / 10)
            columns = {INTERVENTION: np.ones(2, np.float32)}
            bridge.add_step(obs, np.zeros(2, np.float32), reward=0.0, done=t == 2, success=False, columns=columns)
        bridge.end_episode(False)
    finally:
        bridge.close()
    done = run_inproc("stats", str(root), "--json")
    assert done.returncode == 0, done.stderr
    assert "interventions" not in json.loads(done.stdout)  # as without the column: no such table
    assert stats_query([root], "SELECT count(*) AS n FROM intervention_episodes").records() == [{"n": 0}]
