"""Mapping mistakes on bags written by the official writers (rosbags ROS 1 / ROS 2, `mcap_ros2` plain MCAP):
one `error:` line naming the topic and the cause, exit 2, nothing written."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from tests.support import layout_bags as lb
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
    return _refuses(tmp_path, WRITE[kind](tmp_path, flaw), {**MAPPING, **change})


def _refuses(tmp_path: Path, bag: Path, doc: dict[str, Any]) -> str:
    """The one `error:` line (naming `bag`) of a convert that exits 2 and leaves nothing behind."""
    mapping = write_yaml(tmp_path / "m.yaml", doc)
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
        "(a camera needs sensor_msgs/msg/Image, sensor_msgs/msg/CompressedImage, foxglove.RawImage or "
        "foxglove.CompressedImage)"
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


def _split(change: dict[str, Any]) -> dict[str, Any]:
    """The arm + gripper mapping of test_layouts with state part 1 changed."""
    arm = {"topic": "/arm/joint_states", "field": "position", "joints": ["j1", "j2", "j3"]}
    return {
        "fps": 10,
        "task": "pick",
        "state": {"parts": [arm, {"topic": "/gripper/joint_states", "field": "position", **change}]},
        "action": {"parts": [{"topic": "/arm/cmd", "field": "data"}, {"topic": "/gripper/cmd", "field": "data"}]},
    }


@pytest.mark.parametrize("kind", list(lb.WRITERS))
def test_part_width_changing_mid_bag(tmp_path: Path, kind: str) -> None:
    """A driver that adds a value to /gripper/cmd after 0.5 s: never padded or cut, one line naming the part."""
    bag = lb.WRITERS[kind](tmp_path, lb.split(gripper_cmd_width=lambda k: 1 if k < 5 else 2))
    line = _refuses(tmp_path, bag, _split({}))
    assert line.endswith("mapping: action.parts[1] (/gripper/cmd.data): vector length changed from 1 to 2"), line


@pytest.mark.parametrize(
    ("change", "cause"),
    [
        ({"topic": "/gripper/nope"}, "mapped topic(s) /gripper/nope not in the bag (topics: /arm/cmd, "),
        ({"field": "name"}, "mapping: state.parts[1] (/gripper/joint_states.name): field is list, not numbers"),
        (
            {"field": "header"},
            "mapping: state.parts[1] (/gripper/joint_states.header): field is a std_msgs/msg/Header message, not "
            "numbers",
        ),
        ({"joints": ["thumb"]}, "state.parts[1] (/gripper/joint_states.position): joints ['thumb'] not in the "),
        ({"names": ["a", "b"]}, "state.parts[1] (/gripper/joint_states.position): names has 2 entries for 1 values"),
    ],
)
def test_part_mistakes_name_the_part(tmp_path: Path, change: dict[str, Any], cause: str) -> None:
    line = _refuses(tmp_path, lb.write_plain_mcap(tmp_path / "log.mcap", lb.split(400)), _split(change))
    assert cause in line, line


def test_empty_field_of_a_part(tmp_path: Path) -> None:
    """A driver that leaves JointState.effort empty: one line, not a zero-width part."""
    samples = [lb.Sample(s.topic, s.ns, {**s.fields, "effort": s.fields["effort"][:0]}) if "name" in s.fields
               else s for s in lb.split(400)]  # fmt: skip
    line = _refuses(tmp_path, lb.write_ros2(tmp_path / "b", samples), _split({"field": "effort"}))
    assert line.endswith(
        "mapping: state.parts[1] (/gripper/joint_states.effort): the field is empty (no values to map)"
    )
