"""`info SRC` for every source kind: a bag (ROS 1, rosbag2, plain MCAP, a folder of them) shows its topics, types,
counts and rates; a zarr replay buffer or an RLDS build folder its layout, episodes, steps and arrays. Both as a
table and as one line of JSON; a malformed source is one `error:` line, exit 2."""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Any

import pytest

from tests.cli.test_json import parse
from tests.support.bags import samples, write_plain_mcap, write_ros1, write_ros2
from tests.support.inproc import run_inproc
from tests.support.replay_buffer import sample_episodes, write_replay_buffer
from tests.support.rlds_written import write_rlds


def _json(src: str, table: str) -> dict[str, Any]:
    """`info --json SRC`: one line, its fields those docs/scripting.md's `table` lists, of their types."""
    run = run_inproc("info", "--json", src)
    assert run.returncode == 0, run.stderr
    return parse(run.stdout, table)


@pytest.fixture(scope="module")
def bags(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("bags")
    folder = root / "folder"
    folder.mkdir()
    return {
        "ros1": write_ros1(root / "a.bag", depth=True),
        "rosbag2": write_ros2(root / "r2", "mcap"),
        "mcap": write_plain_mcap(root / "p.mcap"),
        "folder": (write_ros1(folder / "1.bag"), write_ros1(folder / "2.bag"))[0].parent,
    }


@pytest.mark.parametrize("kind", ["ros1", "rosbag2", "mcap", "folder"])
def test_info_lists_a_bags_topics(bags: dict[str, Path], kind: str) -> None:
    doc = _json(str(bags[kind]), "info bag")
    expected = Counter(topic for topic, _, _ in samples(depth=kind == "ros1"))
    copies = 2 if kind == "folder" else 1
    topics = {t["topic"]: t for t in doc["topics"]}
    assert doc["kind"] == "bag" and len(doc["bags"]) == copies
    assert {k: t["messages"] for k, t in topics.items()} == {k: n * copies for k, n in expected.items()}
    assert topics["/joint_states"]["type"] == "sensor_msgs/msg/JointState"
    assert topics["/joint_states"]["rate_hz"] == pytest.approx(100, rel=0.02)
    assert topics["/cmd"]["rate_hz"] == pytest.approx(20, rel=0.02)
    assert doc["duration_s"] == pytest.approx(1.99 * copies, abs=0.01)
    table = run_inproc("info", str(bags[kind]))
    assert table.returncode == 0, table.stderr
    assert "/cam2/compressed" in table.stdout and "sensor_msgs/msg/CompressedImage" in table.stdout


def test_info_describes_a_zarr_replay_buffer(tmp_path: Path) -> None:
    path = write_replay_buffer(tmp_path / "b.zarr.zip", sample_episodes((5, 3, 7)), zip_store=True)
    doc = _json(str(path), "info arrays")
    assert (doc["layout"], doc["episodes"], doc["steps"], doc["fps"]) == ("zarr", 3, 15, None)
    assert {"key": "data/img", "dtype": "uint8", "shape": [8, 6, 3], "encoding": "raw"} in doc["arrays"]
    table = run_inproc("info", str(path))
    assert "data/state" in table.stdout and "float32 [5]" in table.stdout and "not stored" in table.stdout


def test_info_describes_an_rlds_folder(tmp_path: Path) -> None:
    folder = write_rlds(tmp_path / "toy" / "1.0.0")
    doc = _json(str(folder.parent), "info arrays")  # the dataset folder holding one version folder
    assert (doc["layout"], doc["episodes"], doc["steps"], doc["source"]) == ("rlds", 3, 15, str(folder))
    assert {"key": "steps/observation/image", "dtype": "uint8", "shape": [12, 16, 3], "encoding": "jpeg"} in doc[
        "arrays"
    ]
    assert doc["languages"] == ["pick up block 0", "pick up block 1", "pick up block 2"]


def test_info_refuses_a_malformed_source_in_one_line(tmp_path: Path) -> None:
    folder = write_rlds(tmp_path / "toy")
    shard = next(folder.glob("*.tfrecord-00000-*"))
    shard.write_bytes(shard.read_bytes()[:-10])
    run = run_inproc("info", str(folder))
    lines = run.stderr.strip().splitlines()
    assert run.returncode == 2 and len(lines) == 1 and lines[0].startswith(f"error: {shard}: record 1: "), run.stderr
