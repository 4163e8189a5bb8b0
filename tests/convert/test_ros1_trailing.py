"""A ROS 1 bag whose sensor_msgs/Image messages carry 4 bytes after `data` (as Intel's RealSense ROS 1 recorder
writes them; ROS 1's own reader ignores them, rosbags refuses them) converts (#45): the pictures are the
messages' pixels, and the report counts the messages with trailing bytes per topic."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from openral_data.replay.recorded import RecordedDataset
from tests.support.bags import MAPPING, expected, write_ros1
from tests.support.inproc import run_inproc
from tests.support.scenes import write_yaml

COLOUR_TOL = 12.0


def test_ros1_images_with_trailing_bytes_convert(tmp_path: Path) -> None:
    bag = write_ros1(tmp_path / "realsense.bag", flaw="trailing-bytes")
    out = tmp_path / "out"
    mapping = write_yaml(tmp_path / "m.yaml", MAPPING)
    run = run_inproc("convert", str(bag), str(out), "--mapping", str(mapping), "--codec", "h264", "--json")
    assert run.returncode == 0, run.stderr
    doc = json.loads(run.stdout)
    trailing = doc["trailing_bytes"]
    assert set(trailing) == {"/cam/image_raw"}  # the Image topic only; CompressedImage and the rest are exact
    assert 0 < trailing["/cam/image_raw"] <= doc["topics"]["/cam/image_raw"]["messages"]
    frames = list(RecordedDataset(out).frames(0))
    assert len(frames) == 20
    for i, frame in enumerate(frames):
        got = frame.images["front"].astype(np.float64).mean(axis=(0, 1))
        assert np.abs(got - np.array(expected(i * 100)["front"])).max() <= COLOUR_TOL, (i, got)
    human = run_inproc("convert", str(bag), str(tmp_path / "again"), "--mapping", str(mapping), "--codec", "h264")
    assert "trailing bytes /cam/image_raw" in human.stdout and "ignored, as ROS 1's own reader does" in human.stdout
