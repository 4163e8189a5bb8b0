"""`convert` on the bag layouts robots produce (tests/support/layout_bags.py, official writers): several roles
from one topic (a Franka-like ROS 1 `/joint_states`: state = position, action = velocity), and vectors
concatenated from several topics in a declared order (split arm/gripper JointState topics + Float64MultiArray
commands). Every value of every frame is checked against the source messages, lerobot 0.6.1 loads the result
and doctor finds it healthy."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import pytest

from openral_data.doctor import check
from openral_data.formats.lerobot_v3.reader import read_episodes
from tests.support import layout_bags as lb
from tests.support.cli import run_cli
from tests.support.scenes import write_yaml

FPS = 10
PERIOD_NS = 10**9 // FPS

# franka_ros: one JointState carries everything; two roles and two parts of one role read it
FRANKA: dict[str, Any] = {
    "fps": FPS,
    "robot_type": "franka_panda",
    "task": "pick",
    "state": {
        "parts": [
            {"topic": "/joint_states", "field": "position", "joints": lb.PANDA},
            {
                "topic": "/joint_states",
                "field": "velocity",
                "joints": lb.PANDA[:7],
                "names": [f"dq{i}" for i in range(1, 8)],
            },
        ]
    },
    "action": {"topic": "/joint_states", "field": "effort", "joints": lb.PANDA[:7]},
}

# the same topic for state and action in the single-source form, as the Franka bag needs
FRANKA_SIMPLE: dict[str, Any] = {
    "fps": FPS,
    "task": "pick",
    "state": {"topic": "/joint_states", "field": "position", "joints": lb.PANDA},
    "action": {"topic": "/joint_states", "field": "velocity", "joints": lb.PANDA},
}

SPLIT: dict[str, Any] = {
    "fps": FPS,
    "robot_type": "arm_and_gripper",
    "task": "pick",
    "state": {
        "parts": [
            {"topic": "/arm/joint_states", "field": "position", "joints": ["j1", "j2", "j3"]},
            {"topic": "/gripper/joint_states", "field": "position", "names": ["finger"]},
        ]
    },
    "action": {
        "parts": [
            {"topic": "/arm/cmd", "field": "data"},
            {"topic": "/gripper/cmd", "field": "data", "names": ["grip"]},
        ]
    },
}


# JointState and Float64MultiArray parts in one vector: the arm's measured velocity + the gripper's command
MIXED: dict[str, Any] = {
    **SPLIT,
    "action": {
        "parts": [
            {"topic": "/arm/joint_states", "field": "velocity", "joints": ["j1", "j2", "j3"],
             "names": ["dq1", "dq2", "dq3"]},
            {"topic": "/gripper/cmd", "field": "data", "names": ["grip"]},
        ]
    },
}  # fmt: skip
NAMES = {
    "split": (
        ["j1", "j2", "j3", "finger"],
        ["arm/cmd.data[0]", "arm/cmd.data[1]", "arm/cmd.data[2]", "grip"],  # a part without names: as before
    ),
    "mixed": (["j1", "j2", "j3", "finger"], ["dq1", "dq2", "dq3", "grip"]),
}


def _convert(tmp_path: Path, bag: Path, mapping: dict[str, Any]) -> dict[str, Any]:
    out = tmp_path / "ds"
    proc = run_cli("convert", str(bag), str(out), "--mapping", str(write_yaml(tmp_path / "m.yaml", mapping)),
                   "--json")  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    doc: dict[str, Any] = json.loads(proc.stdout)
    return doc


def _parts(vector: dict[str, Any]) -> list[dict[str, Any]]:
    parts: list[dict[str, Any]] = vector.get("parts", [vector])
    return parts


def _check_against_source(root: Path, samples: list[lb.Sample], mapping: dict[str, Any], starts: list[int]) -> int:
    """Every frame lerobot loads holds, per dim, the float32 of the value its source message had at the frame
    time (episode e's frames start at grid frame `starts[e]`); returns the frames checked."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/check", root=root)
    topics = [p["topic"] for key in ("state", "action") for p in _parts(mapping[key])]
    t0 = lb.grid_start(samples, topics)
    for i in range(len(ds)):
        item = ds[i]
        ns = t0 + (starts[int(item["episode_index"])] + int(item["frame_index"])) * PERIOD_NS
        for key, feature in (("state", "observation.state"), ("action", "action")):
            want = [v for part in _parts(mapping[key]) for v in lb.part_values(samples, part, ns)]
            got = np.atleast_1d(item[feature].numpy()).tolist()  # lerobot gives a width-1 vector as a scalar
            assert got == want, (key, i, ns)
    assert check(root) == []  # doctor: healthy
    return len(ds)


def _names(root: Path) -> tuple[list[str], list[str]]:
    features = json.loads((root / "meta" / "info.json").read_text())["features"]
    return features["observation.state"]["names"], features["action"]["names"]


@pytest.mark.parametrize("mapping", [FRANKA_SIMPLE, FRANKA], ids=["single", "parts"])
def test_franka_joint_states_in_several_roles(tmp_path: Path, mapping: dict[str, Any]) -> None:
    samples = lb.franka()
    bag = lb.write_ros1(tmp_path / "franka.bag", samples)
    doc = _convert(tmp_path, bag, mapping)
    assert _check_against_source(tmp_path / "ds", samples, mapping, [0]) == 10
    # one topic, read once: its messages are counted once however many roles use it
    assert doc["topics"]["/joint_states"]["messages"] == 100
    state, action = _names(tmp_path / "ds")
    if mapping is FRANKA:
        assert state == [*lb.PANDA, *[f"dq{i}" for i in range(1, 8)]] and action == lb.PANDA[:7]
    else:
        assert state == action == lb.PANDA


@pytest.mark.parametrize("kind", list(lb.WRITERS))
@pytest.mark.parametrize("layout", list(NAMES))
def test_arm_and_gripper_topics_concatenated(tmp_path: Path, kind: str, layout: str) -> None:
    samples = lb.split()
    bag = lb.WRITERS[kind](tmp_path, samples)
    mapping = SPLIT if layout == "split" else MIXED
    doc = _convert(tmp_path, bag, mapping)
    assert _check_against_source(tmp_path / "ds", samples, mapping, [0]) == 10
    assert _names(tmp_path / "ds") == NAMES[layout]
    counts = {"/arm/joint_states": 50, "/gripper/joint_states": 31, "/arm/cmd": 20, "/gripper/cmd": 10}
    assert {t: r["messages"] for t, r in doc["topics"].items()} == {t: counts[t] for t in doc["topics"]}
    assert list(doc["topics"]) == list(
        dict.fromkeys(p["topic"] for k in ("state", "action") for p in _parts(mapping[k]))
    )


def test_each_part_aligns_on_its_own(tmp_path: Path) -> None:
    """The gripper goes quiet for 350 ms: only the frames where *its* newest sample is too old are unfillable
    (the arm's parts fill every frame), the episode splits there, and the values around the hole are exact."""
    samples = [
        s
        for s in lb.split()
        if not (s.topic == "/gripper/joint_states" and 350 * lb.MS <= s.ns - lb.BASE < 700 * lb.MS)
    ]
    bag = lb.write_ros2(tmp_path / "holes", samples)
    doc = _convert(tmp_path, bag, SPLIT)
    # gripper samples at 330 then 726 ms: frames 500, 600, 700 ms have none within 100 ms
    assert doc["unfillable_frames"] == 3 and doc["splits"] == 1
    assert {t: r["unfillable_frames"] for t, r in doc["topics"].items()} == {
        "/arm/joint_states": 0,
        "/gripper/joint_states": 3,
        "/arm/cmd": 0,
        "/gripper/cmd": 0,
    }
    assert [e["length"] for e in doc["episode_list"]] == [5, 2]
    assert _check_against_source(tmp_path / "ds", samples, SPLIT, [0, 8]) == 7


STATUS = "robot_msgs/msg/Status"


def _status_bag(path: Path) -> list[lb.Sample]:
    """A robot's own status message (a custom type, its definition in the bag) carrying everything at 50 Hz."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg("float64[] position\nfloat64[] velocity\nfloat64 reward\nbool success\n", STATUS))
    samples = [
        lb.Sample("/status", lb.BASE + k * 20 * lb.MS, {"position": [k * 0.5, -k * 1.0], "velocity": [k + 0.25],
                                                         "reward": k * 0.125, "success": k >= 30})
        for k in range(50)
    ]  # fmt: skip
    with Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection("/status", STATUS, typestore=store)
        for s in samples:
            msg = store.types[STATUS](**{k: np.asarray(v) if isinstance(v, list) else v for k, v in s.fields.items()})
            writer.write(conn, s.ns, store.serialize_cdr(msg, STATUS))
    return samples


def test_every_role_from_one_status_topic(tmp_path: Path) -> None:
    """state, action, reward and success all read their own field of one topic's messages."""
    samples = _status_bag(tmp_path / "status")
    mapping = {
        "fps": FPS,
        "task": "pick",
        "state": {"topic": "/status", "field": "position", "names": ["x", "y"]},
        "action": {"topic": "/status", "field": "velocity", "names": ["v"]},
        "reward": {"topic": "/status", "field": "reward"},
        "success": {"topic": "/status", "field": "success"},
    }
    doc = _convert(tmp_path, tmp_path / "status", mapping)
    assert doc["topics"]["/status"]["messages"] == 50 and doc["reward_topic"] == doc["success_topic"] == "/status"
    assert _check_against_source(tmp_path / "ds", samples, mapping, [0]) == 10
    frames = pq.read_table(tmp_path / "ds" / "data").sort_by("index")
    at = [lb.latest(samples, "/status", lb.BASE + i * PERIOD_NS).fields for i in range(10)]
    assert frames.column("next.reward").to_pylist() == [f["reward"] for f in at]
    assert frames.column("next.success").to_pylist() == [f["success"] for f in at] == [False] * 6 + [True] * 4
    assert read_episodes(tmp_path / "ds").column("openral.success").to_pylist() == [True]
