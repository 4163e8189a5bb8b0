"""Mapping mistakes on bags written by the official writers (rosbags ROS 1 / ROS 2, `mcap_ros2` plain MCAP):
one `error:` line naming the topic and the cause, exit 2, nothing written."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from tests.support.bags import MAPPING, Flaw, write_plain_mcap, write_ros1, write_ros2
from tests.support.cli import run_cli
from tests.support.scenes import write_yaml

WRITE = {
    "ros1": lambda d, flaw: write_ros1(d / "log.bag", flaw, duration_ms=400),
    "ros2-mcap": lambda d, flaw: write_ros2(d / "log_mcap", "mcap", flaw, duration_ms=400),
    "ros2-sqlite3": lambda d, flaw: write_ros2(d / "log_sqlite", "sqlite3", flaw, duration_ms=400),
    "plain-mcap": lambda d, flaw: write_plain_mcap(d / "log.mcap", flaw, duration_ms=400),
}


def _refused(tmp_path: Path, kind: str, flaw: Flaw, change: dict[str, Any]) -> str:
    bag = WRITE[kind](tmp_path, flaw)
    mapping = write_yaml(tmp_path / "m.yaml", {**MAPPING, **change})
    out = tmp_path / "ds"
    proc = run_cli("convert", str(bag), str(out), "--mapping", str(mapping), "--codec", "h264")
    assert proc.returncode == 2, proc.stdout + proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {bag}: "), proc.stderr
    assert not out.exists() and not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
    return lines[0]


@pytest.mark.parametrize("kind", list(WRITE))
def test_camera_on_a_non_image_topic(tmp_path: Path, kind: str) -> None:
    line = _refused(tmp_path, kind, "none", {"cameras": {"front": "/cam/image_raw", "side": "/joint_states"}})
    assert line.endswith(
        "mapping: cameras.side (/joint_states): the topic carries sensor_msgs/msg/JointState, not images "
        "(a camera needs sensor_msgs/msg/Image or sensor_msgs/msg/CompressedImage)"
    ), line


@pytest.mark.parametrize("kind", list(WRITE))
@pytest.mark.parametrize("encoding", ["16UC1", "32FC1"])
def test_depth_image_mapped_as_a_camera(tmp_path: Path, kind: str, encoding: Flaw) -> None:
    line = _refused(tmp_path, kind, encoding, {})
    assert line.endswith(
        f"mapping: cameras.front (/cam/image_raw): {encoding} is a depth image, not an RGB camera "
        "(map a 16UC1/32FC1 depth topic under depth_cameras instead)"
    ), line


@pytest.mark.parametrize("kind", ["ros1", "plain-mcap"])
def test_compressed_depth_mapped_as_a_camera(tmp_path: Path, kind: str) -> None:
    line = _refused(tmp_path, kind, "compressedDepth", {})
    assert line.endswith(
        "mapping: cameras.side (/cam2/compressed): a CompressedImage of format '16UC1; compressedDepth png' is a "
        "depth image, not an RGB camera (map a 16UC1/32FC1 depth topic under depth_cameras instead)"
    ), line


@pytest.mark.parametrize("kind", list(WRITE))
def test_all_zero_header_stamps_with_clock_header(tmp_path: Path, kind: str) -> None:
    line = _refused(tmp_path, kind, "zero-stamps", {"align": {**MAPPING["align"], "clock": "header"}})
    assert ": /joint_states: header stamps are all zero, so align.clock: header cannot place its messages; " in line
    assert line.endswith("(set align.clock: log in the mapping to align on receive time)"), line


def test_zero_stamps_convert_on_the_log_clock(tmp_path: Path) -> None:
    """The same bag converts with the default `align.clock: log`: the refusal is about the clock, not the bag."""
    bag = WRITE["ros2-mcap"](tmp_path, "zero-stamps")
    mapping = write_yaml(tmp_path / "m.yaml", MAPPING)
    proc = run_cli("convert", str(bag), str(tmp_path / "ds"), "--mapping", str(mapping), "--codec", "h264")
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "ds" / "meta" / "info.json").is_file()
