"""`align.clock: header` lives entirely in the header time base: a bag whose header stamps are simulation time
(seconds from 0, as Gazebo stamps them) while the bag logs wall-clock time converts on the documented grid, with
no message dropped as late; messages without a header are placed in the stamps' time base."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import pyarrow.parquet as pq
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from tests.support.bags import BASE, MS, TYPES, build, samples
from tests.support.inproc import run_inproc
from tests.support.scenes import write_yaml

LATENCY_MS = {"/joint_states": 35, "/cam/image_raw": 45}  # log time - stamp; /cmd has no header
SIM_START_NS = 12 * 10**9  # the simulation clock read 12 s when the wall-clock recording began
MAPPING: dict[str, Any] = {
    "fps": 10,
    "task": "pick",
    "state": {"topic": "/joint_states", "field": "position", "joints": ["j1", "j2", "j3"]},
    "action": {"topic": "/cmd", "field": "data"},
    "cameras": {"front": "/cam/image_raw"},
    "align": {"method": "previous", "max_staleness": 0.1, "clock": "header"},
}


def _write_sim_time_bag(path: Path) -> Path:
    """A rosbag2/MCAP bag (rosbags' writer): log time is wall clock, every header stamp is simulation time."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    topics = ("/joint_states", "/cmd", "/cam/image_raw")
    with Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as writer:
        conns = {t: writer.add_connection(t, TYPES[t], typestore=store) for t in topics}
        rows = []
        for topic, wall_ns, f in samples(duration_ms=1000):
            if topic in topics:
                sim_ns = wall_ns - BASE + SIM_START_NS
                log_ns = wall_ns + LATENCY_MS.get(topic, 0) * MS
                rows.append((log_ns, topic, build(store, topic, sim_ns, f, False)))
        for log_ns, topic, msg in sorted(rows, key=lambda r: r[0]):
            writer.write(conns[topic], log_ns, store.serialize_cdr(msg, TYPES[topic]))
    return path


def test_sim_time_stamps_align_on_the_header_grid(tmp_path: Path) -> None:
    bag = _write_sim_time_bag(tmp_path / "bag")
    mapping = write_yaml(tmp_path / "m.yaml", MAPPING)
    out = tmp_path / "out"
    proc = run_inproc("convert", str(bag), str(out), "--mapping", str(mapping), "--codec", "h264")
    assert proc.returncode == 0, proc.stderr
    assert re.search(r"late messages +0 not used", proc.stdout), proc.stdout
    table = pq.read_table(out / "data").sort_by("index")
    # the grid starts at sim stamp 12 s (every stream's first sample) and ends at the last message: frame j at
    # 100 j ms takes joint state k = 10 j and command k = 2 j (its log time placed in the sim time base)
    states = table.column("observation.state").to_pylist()
    assert states == [[10 * j, 20 * j + 0.5, 30 * j] for j in range(10)]
    assert table.column("action").to_pylist() == [[2 * j, -2 * j] for j in range(10)]
    assert table.column("timestamp").to_pylist() == pytest.approx([0.1 * j for j in range(10)], abs=1e-6)
