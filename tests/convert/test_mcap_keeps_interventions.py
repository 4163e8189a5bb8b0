"""MCAP keeps who drove and the interventions (issue #32): an intervention session recorded as LeRobot and MCAP at
once holds the same flags, proposals and episode info in both; dataset -> MCAP -> dataset gives them back with the
same dtype, shape and names (the SQL views agree, lerobot loads the result); a plain recording's bag keeps its
topics.

The session is the fixed-rate loop on the UR5e twin with the real `KeyboardOperator` reading a pty and the real
`Intervention` / `TakeoverSwitch`: the person types `t` into the terminal while given frames are worked on.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pyarrow.parquet as pq
import pytest
from rosbags.highlevel import AnyReader

from openral_data.columns import INTERVENTION, POLICY_ACTION
from openral_data.formats.mcap import finished_bags
from openral_data.metrics.command import stats_query
from openral_data.policies.intervention import (
    Intervention,
    TakeoverSwitch,
    intervention_columns,
)
from openral_data.producers.hal.session.operator import KeyboardOperator
from openral_data.record.hal_loop import EpisodeEnd
from openral_data.runtime import registry
from openral_data.types import Observation
from tests.support.bags import MAPPING, write_ros2
from tests.support.hal import episode_infos, frames_table, run_loop, ur5e_twin
from tests.support.hdf5_layouts import write_robomimic
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import loaded_episodes
from tests.support.scenes import mock_scene, write_yaml

FRAMES = 14
PRESSES = {3, 9}  # `t` typed while these frames are worked on: the person drives frames 4..9


class _Pressing:
    """The sweep policy; a person types `t` into the terminal (`master`) while the frames in `PRESSES` are worked on."""

    def __init__(self, master: int) -> None:
        rskill, path = registry.resolve_rskill("sweep-ur5e")
        self.inner = registry.policy_factory(rskill, str(path))(rskill)
        self.master, self.steps = master, 0

    def reset(self, seed: int) -> None:
        self.inner.reset(seed)

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        if self.steps in PRESSES:
            os.write(self.master, b"t")
        self.steps += 1
        return self.inner.step(observation, instruction)

    def close(self) -> None:
        self.inner.close()


class _Nudge:
    """The person's device: from the action in effect at the takeover, the first joint a little further each tick."""

    def __init__(self) -> None:
        self.action: npt.NDArray[np.float32] | None = None

    def take_over(self, action: npt.NDArray[np.float32]) -> None:
        self.action = action.copy()

    def reset(self, seed: int) -> None:
        self.action = None

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        assert self.action is not None
        self.action[0] += 0.01
        return self.action.copy()

    def close(self) -> None:
        pass


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One intervention episode recorded as a LeRobot dataset with its MCAP bags in `mcap/`."""
    out = tmp_path_factory.mktemp("interv") / "ds"
    rskill, _ = registry.resolve_rskill("sweep-ur5e")
    master, slave = os.openpty()
    switch = TakeoverSwitch()
    operator = KeyboardOperator(fd=slave, listener=switch.feed)
    policy = Intervention(_Pressing(master), _Nudge(), switch)
    os.write(master, b" ")  # space: start the episode
    try:
        columns = intervention_columns(rskill.action_contract.names)
        hal = ur5e_twin(cameras=[])
        [(end, rep)] = run_loop(hal, policy, operator, out, max_steps=FRAMES, columns=columns, mcap=out / "mcap")
    finally:
        operator.close()
        os.close(master)
        os.close(slave)
    assert end is EpisodeEnd.KEPT and rep.frames == FRAMES
    return out


def _bag(bag: Path) -> dict[str, list[Any]]:
    """Every message of `bag` by topic, read with rosbags (markers as parsed JSON)."""
    out: dict[str, list[Any]] = {}
    with AnyReader([bag]) as reader:
        for conn, _, raw in reader.messages():
            msg: Any = reader.deserialize(raw, conn.msgtype)
            out.setdefault(conn.topic, []).append(json.loads(msg.data) if conn.topic == "/openral/episode" else msg)
    return out


def _sql(ds: Path) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    runs = stats_query([ds], "SELECT episode_index, start_frame, end_frame, length FROM interventions")
    ops = stats_query([ds], "SELECT episode_index, operator FROM episodes ORDER BY episode_index")
    return runs.records(), ops.records()


def test_the_bags_hold_the_flags_proposals_and_who_drove(session: Path) -> None:
    cols = frames_table(session)
    flags = cols[INTERVENTION]
    assert flags == [4 <= i < 10 for i in range(FRAMES)]  # the recording itself is an intervention session
    [bag] = finished_bags(session / "mcap")
    msgs = _bag(bag)
    assert [bool(m.data) for m in msgs["/openral/intervention"]] == flags
    proposals = np.stack([np.asarray(m.data, dtype=np.float32) for m in msgs["/openral/policy_action"]])
    assert np.array_equal(proposals, np.array(cols[POLICY_ACTION], dtype=np.float32))
    names = json.loads((session / "meta" / "info.json").read_text())["features"][POLICY_ACTION]["names"]
    assert msgs["/openral/policy_action"][0].layout.dim[0].label == POLICY_ACTION
    start, end = msgs["/openral/episode"]
    assert start["frame_columns"] == {
        POLICY_ACTION: {"topic": "/openral/policy_action", "dtype": "float32", "names": names},
        INTERVENTION: {"topic": "/openral/intervention", "dtype": "bool", "names": []},
    }
    assert end["info"] == episode_infos(session)[0] and end["info"]["operator"] == "script"


def test_dataset_to_mcap_and_back_keeps_them(session: Path, tmp_path: Path) -> None:
    bags, back = tmp_path / "bags", tmp_path / "back"
    for args in ((str(session), str(bags)), (str(bags), str(back), "--codec", "h264")):
        done = run_inproc("convert", *args)
        assert done.returncode == 0, done.stderr
    want, got = frames_table(session), frames_table(back)
    assert got[INTERVENTION] == want[INTERVENTION]
    assert np.array_equal(np.array(got[POLICY_ACTION], np.float32), np.array(want[POLICY_ACTION], np.float32))
    features = [json.loads((d / "meta" / "info.json").read_text())["features"] for d in (session, back)]
    assert features[1][INTERVENTION] == features[0][INTERVENTION] == {"dtype": "bool", "shape": [1], "names": None}
    assert features[1][POLICY_ACTION] == features[0][POLICY_ACTION]
    assert episode_infos(back) == episode_infos(session)
    runs, ops = _sql(back)
    assert (runs, ops) == _sql(session) and ops == [{"episode_index": 0, "operator": "script"}]
    assert runs == [{"episode_index": 0, "start_frame": 4, "end_frame": 10, "length": 6}]
    [loaded] = loaded_episodes(back)
    [original] = loaded_episodes(session)
    assert [f["action"] for f in loaded] == [f["action"] for f in original]
    assert [f["state"] for f in loaded] == [f["state"] for f in original]


def test_a_plain_recordings_bags_keep_their_topics(tmp_path: Path) -> None:
    scene = write_yaml(tmp_path / "scene.yaml", mock_scene(n_episodes=1, max_steps=4))
    out = tmp_path / "ds"
    done = run_inproc("record", "--scene", str(scene), "--out", str(out), "--codec", "h264", "--format", "lerobot,mcap")
    assert done.returncode == 0, done.stderr
    [bag] = finished_bags(out / "mcap")
    with AnyReader([bag]) as reader:
        topics = [(c.topic, c.msgtype) for c in reader.connections]
    assert topics == [
        ("/openral/episode", "std_msgs/msg/String"),
        ("/task", "std_msgs/msg/String"),
        ("/joint_states", "sensor_msgs/msg/JointState"),
        ("/action", "std_msgs/msg/Float32MultiArray"),
        ("/reward", "std_msgs/msg/Float32"),
        ("/camera/front/image/compressed", "sensor_msgs/msg/CompressedImage"),
        ("/camera/wrist/image/compressed", "sensor_msgs/msg/CompressedImage"),
    ]
    start = _bag(bag)["/openral/episode"][0]
    assert "frame_columns" not in start
    back = tmp_path / "back"  # who drove comes back too
    assert run_inproc("convert", str(out / "mcap"), str(back), "--codec", "h264").returncode == 0
    assert episode_infos(back) == episode_infos(out)
    values = [
        [{k: f[k] for k in ("state", "action", "task", "success")} for f in loaded_episodes(d)[0]] for d in (back, out)
    ]
    assert values[0] == values[1]


def test_a_mapping_maps_columns_of_a_foreign_bag(tmp_path: Path) -> None:
    bag = write_ros2(tmp_path / "b", "mcap", duration_ms=500)
    columns = {"my.cmd": {"topic": "/cmd", "field": "data", "names": ["a", "b"]}}
    mapping = write_yaml(tmp_path / "m.yaml", {**MAPPING, "columns": columns})
    out = tmp_path / "ds"
    done = run_inproc("convert", str(bag), str(out), "--mapping", str(mapping), "--codec", "h264")
    assert done.returncode == 0, done.stderr
    feature = json.loads((out / "meta" / "info.json").read_text())["features"]["my.cmd"]
    assert feature == {"dtype": "float32", "shape": [2], "names": ["a", "b"]}
    cols = frames_table(out)
    assert cols["my.cmd"] == cols["action"]  # the same field of the same messages
    [episodes] = sorted((out / "meta" / "episodes").rglob("*.parquet"))
    assert pq.read_table(episodes).column("openral.episode_info").to_pylist() == [None]  # nobody said who drove


@pytest.mark.parametrize(
    ("columns", "message"),
    [
        ({"action": {"topic": "/cmd"}}, "columns: 'action' is not a free feature name"),
        ({"f": {"topic": "/cmd", "dtype": "bool", "names": ["a"]}}, "a bool column has no names"),
        ({"f": {"topic": "/cmd", "dtype": "bool"}}, "mapping: columns.f: 2 values for one flag"),
        ({"f": {"topic": "/cam/image_raw"}}, "columns.f topic /cam/image_raw is also mapped as a camera"),
    ],
)
def test_bad_columns_are_one_line(tmp_path: Path, columns: dict[str, Any], message: str) -> None:
    bag = write_ros2(tmp_path / "b", "mcap", duration_ms=300)
    mapping = write_yaml(tmp_path / "m.yaml", {**MAPPING, "columns": columns})
    out = tmp_path / "ds"
    done = run_inproc("convert", str(bag), str(out), "--mapping", str(mapping), "--codec", "h264")
    lines = done.stderr.strip().splitlines()
    assert done.returncode == 2 and len(lines) == 1 and lines[0].startswith("error: "), done.stderr
    assert message in lines[0], lines[0]
    assert not out.exists()


def test_array_sources_refuse_columns(tmp_path: Path) -> None:
    src = write_robomimic(tmp_path / "demo.hdf5", lengths=(3,))
    printed = run_inproc("convert", str(src), "--print-mapping", "--json")
    assert printed.returncode == 0, printed.stderr
    columns = {"my.flag": {"topic": "data/demo_0/dones", "dtype": "bool"}}
    mapping = write_yaml(tmp_path / "m.yaml", {**json.loads(printed.stdout)["mapping"], "columns": columns})
    out = tmp_path / "ds"
    done = run_inproc("convert", str(src), str(out), "--mapping", str(mapping), "--codec", "h264")
    assert done.returncode == 2 and "columns: bags only" in done.stderr and len(done.stderr.splitlines()) == 1
    assert not out.exists()
