"""`align.clock: header`: frames are aligned on `header.stamp` (messages without a header keep their log time),
checked on a real rosbag2/MCAP log whose camera and joint states are logged 45 / 35 ms after their stamps."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from tests.support.bags import MS, TYPES, build, samples
from tests.support.cli import run_cli
from tests.support.scenes import write_yaml

LATENCY_MS = {"/joint_states": 35, "/cam/image_raw": 45}  # log time - header stamp; /cmd has no header
MAPPING: dict[str, Any] = {
    "fps": 10,
    "task": "pick",
    "state": {"topic": "/joint_states", "field": "position", "joints": ["j1", "j2", "j3"]},
    "action": {"topic": "/cmd", "field": "data"},
    "cameras": {"front": "/cam/image_raw"},
    "align": {"method": "previous", "max_staleness": 0.1},
}


def _write(path: Path) -> Path:
    store = get_typestore(Stores.ROS2_HUMBLE)
    topics = ("/joint_states", "/cmd", "/cam/image_raw")
    with Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as writer:
        conns = {t: writer.add_connection(t, TYPES[t], typestore=store) for t in topics}
        rows = []
        for topic, stamp_ns, f in samples(duration_ms=1000):
            if topic in topics:  # the message carries its stamp; the bag logs it later
                rows.append((stamp_ns + LATENCY_MS.get(topic, 0) * MS, topic, build(store, topic, stamp_ns, f, False)))
        for log_ns, topic, msg in sorted(rows, key=lambda r: r[0]):
            writer.write(conns[topic], log_ns, store.serialize_cdr(msg, TYPES[topic]))
    return path


def _convert(tmp_path: Path, name: str, align: dict[str, Any]) -> tuple[str, list[list[float]], list[list[float]]]:
    mapping = write_yaml(tmp_path / f"{name}.yaml", {**MAPPING, "align": {**MAPPING["align"], **align}})
    out = tmp_path / name
    proc = run_cli("convert", str(tmp_path / "bag"), str(out), "--mapping", str(mapping), "--codec", "h264")
    assert proc.returncode == 0, proc.stderr
    table = pq.read_table(out / "data").sort_by("index")
    return proc.stdout, table.column("observation.state").to_pylist(), table.column("action").to_pylist()


def _state(k: int) -> list[float]:
    return [k, 2 * k + 0.5, 3 * k]


def test_header_stamps_versus_log_time(tmp_path: Path) -> None:
    _write(tmp_path / "bag")
    # header: the grid starts at stamp 0 (every stream's first sample), frame j at 100 j ms takes the samples
    # stamped at or before it: joint state k = 10 j, command k = 2 j
    out, states, actions = _convert(tmp_path, "header", {"clock": "header"})
    assert re.search(r"late messages +0 not used", out), out
    assert states == [_state(10 * j) for j in range(10)]
    assert actions == [[2 * j, -2 * j] for j in range(10)]
    # log (the default): the grid starts when the first image is logged (45 ms); joint states logged by then
    # were stamped 35 ms earlier, so frame j holds k = 10 j + 1: log time and header stamps really differ
    _, states, actions = _convert(tmp_path, "log", {})
    assert states == [_state(10 * j + 1) for j in range(len(states))]
    assert actions == [[2 * j, -2 * j] for j in range(len(actions))]
    assert not np.array_equal(states[: len(states)], [_state(10 * j) for j in range(len(states))])


def test_stamps_later_than_the_reorder_window_are_reported(tmp_path: Path) -> None:
    _write(tmp_path / "bag")
    out, states, _ = _convert(tmp_path, "tight", {"clock": "header", "reorder": 0.01, "max_staleness": 0.2})
    late = int(out.split("late messages")[1].split()[0])
    assert late > 0  # stamped 35 / 45 ms before they were logged: older than what a 10 ms window released
    assert all(s[0] == int(s[0]) for s in states)  # what was used are real samples, nothing invented
