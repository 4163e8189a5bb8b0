"""Bags in the layouts robots actually produce, written by the official writers (rosbags ROS 1 and ROS 2,
`mcap_ros2` for plain MCAP), and what a frame must hold under `previous` alignment, read from the messages.

* `franka`: one ROS 1 `/joint_states` (sensor_msgs/JointState, 100 Hz) as franka_ros publishes it: seven
  `panda_joint*` and two `panda_finger_joint*` names, position, velocity and effort all filled.
* `split`: arm and gripper on separate JointState topics at their own rates (`/arm/joint_states` 50 Hz, names
  [j3, j1, j2]; `/gripper/joint_states` 30 Hz, [finger]) and their commands as `Float64MultiArray`
  (`/arm/cmd` 20 Hz, 3 values; `/gripper/cmd` 10 Hz, 1 value).
* `object_poses`: a tracked object's pose (x, y, yaw) as a `Float64MultiArray` on `/object/pose` at 25 Hz (what a
  mapping's `environment_state` reads).

Every value is a function of the topic, the sample's index k and the dimension, distinct everywhere, so a
frame that took the wrong sample, the wrong field or the wrong joint cannot match.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

BASE = 1_700_000_000 * 10**9
MS = 10**6
JOINT_STATE = "sensor_msgs/msg/JointState"
ARRAY = "std_msgs/msg/Float64MultiArray"
STRING = "std_msgs/msg/String"  # a Sample whose `data` is a str (e.g. a task topic)
PANDA = [f"panda_joint{i}" for i in range(1, 8)] + ["panda_finger_joint1", "panda_finger_joint2"]


@dataclass(frozen=True)
class Sample:
    """One message: plain field values (`name`/`position`/`velocity`/`effort` or `data`)."""

    topic: str
    ns: int
    fields: dict[str, Any]


def _joint_states(topic: str, names: list[str], period_ms: int, duration_ms: int, seed: float) -> list[Sample]:
    out = []
    for k, t in enumerate(range(0, duration_ms, period_ms)):
        j = np.arange(len(names), dtype=np.float64)
        out.append(
            Sample(
                topic,
                BASE + t * MS,
                {
                    "name": list(names),
                    "position": seed + k * 0.01 + j,
                    "velocity": -(seed + k + j * 0.1),
                    "effort": seed * 10 + k * 0.5 + j * 100,
                },
            )
        )
    return out


def _arrays(topic: str, width: Callable[[int], int], period_ms: int, duration_ms: int, seed: float) -> list[Sample]:
    return [
        Sample(topic, BASE + t * MS, {"data": seed + k + np.arange(width(k), dtype=np.float64) * 0.25})
        for k, t in enumerate(range(0, duration_ms, period_ms))
    ]


def franka(duration_ms: int = 1000) -> list[Sample]:
    return _joint_states("/joint_states", PANDA, 10, duration_ms, 1.0)


def split(duration_ms: int = 1000, gripper_cmd_width: Callable[[int], int] = lambda k: 1) -> list[Sample]:
    """The split layout; `gripper_cmd_width(k)`: the width of the k-th /gripper/cmd message (a driver that
    changes it mid-bag)."""
    return [
        *_joint_states("/arm/joint_states", ["j3", "j1", "j2"], 20, duration_ms, 2.0),
        *_joint_states("/gripper/joint_states", ["finger"], 33, duration_ms, 3.0),
        *_arrays("/arm/cmd", lambda k: 3, 50, duration_ms, 4.0),
        *_arrays("/gripper/cmd", gripper_cmd_width, 100, duration_ms, 5.0),
    ]


def object_poses(duration_ms: int = 1000) -> list[Sample]:
    return _arrays("/object/pose", lambda k: 3, 40, duration_ms, 6.0)


def _types(samples: list[Sample]) -> dict[str, str]:
    return {s.topic: _type(s) for s in samples}


def _type(sample: Sample) -> str:
    if "name" in sample.fields:
        return JOINT_STATE
    return STRING if isinstance(sample.fields["data"], str) else ARRAY


def _ordered(samples: list[Sample]) -> list[Sample]:
    return sorted(samples, key=lambda s: s.ns)  # stable: same-time samples keep their topic order


def _message(store: Any, sample: Sample, ros1: bool) -> Any:
    t = store.types
    if _type(sample) == STRING:
        return t[STRING](data=sample.fields["data"])
    if "data" in sample.fields:
        layout = t["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0)
        return t[ARRAY](layout=layout, data=sample.fields["data"])
    stamp = t["builtin_interfaces/msg/Time"](sec=sample.ns // 10**9, nanosec=sample.ns % 10**9)
    header = t["std_msgs/msg/Header"](**({"seq": 0} if ros1 else {}), stamp=stamp, frame_id="")
    f = sample.fields
    return t[JOINT_STATE](header=header, name=f["name"], position=f["position"], velocity=f["velocity"],
                          effort=f["effort"])  # fmt: skip


def write_ros1(path: Path, samples: list[Sample]) -> Path:
    store = get_typestore(Stores.ROS1_NOETIC)
    with Writer1(path) as writer:
        conns = {topic: writer.add_connection(topic, ty, typestore=store) for topic, ty in _types(samples).items()}
        for s in _ordered(samples):
            writer.write(conns[s.topic], s.ns, store.serialize_ros1(_message(store, s, True), conns[s.topic].msgtype))
    return path


def write_ros2(path: Path, samples: list[Sample]) -> Path:
    store = get_typestore(Stores.ROS2_HUMBLE)
    with Writer2(path, version=8, storage_plugin=StoragePlugin.MCAP) as writer:
        conns = {topic: writer.add_connection(topic, ty, typestore=store) for topic, ty in _types(samples).items()}
        for s in _ordered(samples):
            writer.write(conns[s.topic], s.ns, store.serialize_cdr(_message(store, s, False), conns[s.topic].msgtype))
    return path


def write_plain_mcap(path: Path, samples: list[Sample]) -> Path:
    """A plain .mcap written by the `mcap` package's ROS 2 writer (dict messages)."""
    from mcap_ros2.writer import Writer as McapRos2Writer

    store = get_typestore(Stores.ROS2_HUMBLE)
    with path.open("wb") as fh:
        writer = McapRos2Writer(fh)
        schemas = {
            topic: writer.register_msgdef(ty, store.generate_msgdef(ty, ros_version=2)[0])
            for topic, ty in _types(samples).items()
        }
        for s in _ordered(samples):
            msg = {k: v.tolist() if isinstance(v, np.ndarray) else v for k, v in s.fields.items()}
            if "data" in msg:
                msg["layout"] = {"dim": [], "data_offset": 0}
            else:
                msg["header"] = {"stamp": {"sec": s.ns // 10**9, "nanosec": s.ns % 10**9}, "frame_id": ""}
            writer.write_message(s.topic, schemas[s.topic], msg, log_time=s.ns, publish_time=s.ns)
        writer.finish()
    return path


WRITERS: dict[str, Callable[[Path, list[Sample]], Path]] = {
    "ros1": lambda d, s: write_ros1(d / "log.bag", s),
    "ros2-mcap": lambda d, s: write_ros2(d / "log_ros2", s),
    "plain-mcap": lambda d, s: write_plain_mcap(d / "log.mcap", s),
}


def latest(samples: list[Sample], topic: str, ns: int) -> Sample:
    """The topic's last sample at or before `ns` (what `previous` alignment takes)."""
    return [s for s in samples if s.topic == topic and s.ns <= ns][-1]


def grid_start(samples: list[Sample], topics: list[str]) -> int:
    """When the frame grid starts: the time every mapped topic has delivered a sample."""
    return max(min(s.ns for s in samples if s.topic == t) for t in topics)


def part_values(samples: list[Sample], part: dict[str, Any], ns: int) -> list[float]:
    """A mapping part's values at frame time `ns`, read from the source message as float32, in the part's
    order (`joints` picked by name)."""
    msg = latest(samples, part["topic"], ns)
    values = np.asarray(msg.fields[part.get("field", "position")], np.float64)
    if "joints" in part:
        values = values[[msg.fields["name"].index(j) for j in part["joints"]]]
    return [float(v) for v in values.astype(np.float32)]
