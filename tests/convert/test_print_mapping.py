"""`convert BAG --print-mapping`: a starting mapping for a bag nobody described, its guesses marked; saved and
passed back with `--mapping` it converts the bag. `convert BAG OUT` without a mapping points at it."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import yaml

from openral_data.schemas.mapping import load_mapping
from tests.cli.test_json import parse
from tests.support.bags import write_plain_mcap, write_ros1, write_ros2
from tests.support.inproc import run_inproc


def _printed(bag: Path, tmp_path: Path) -> Path:
    run = run_inproc("convert", str(bag), "--print-mapping")
    assert run.returncode == 0, run.stderr
    assert run.stdout.count("# GUESS:") >= 5
    path = tmp_path / "guessed.yaml"
    path.write_text(run.stdout)
    return path


@pytest.mark.parametrize("kind", ["ros1-depth", "mcap"])
def test_the_printed_mapping_converts_the_bag(tmp_path: Path, kind: str) -> None:
    bag = write_ros1(tmp_path / "a.bag", depth=True) if kind == "ros1-depth" else write_plain_mcap(tmp_path / "p.mcap")
    mapping = _printed(bag, tmp_path)
    out = tmp_path / "out"
    run = run_inproc("convert", str(bag), str(out), "--mapping", str(mapping), "--codec", "h264", "--json")
    assert run.returncode == 0, run.stderr
    doc = json.loads(run.stdout)
    assert doc["frames"] == 20 and (out / "meta/info.json").is_file()


def test_the_guesses(tmp_path: Path) -> None:
    m = load_mapping(_printed(write_ros1(tmp_path / "a.bag", depth=True), tmp_path))
    assert (m.fps, m.task_topic) == (10, "/task")
    assert (m.state.topic, m.state.field, m.state.joints) == ("/joint_states", "position", ["extra", "j2", "j1", "j3"])
    assert (m.action.topic, m.action.field) == ("/cmd", "data")
    assert m.cameras == {"cam": "/cam/image_raw", "cam2": "/cam2/compressed"}
    assert m.depth_cameras["camera_depth"] == "/camera/depth/image_rect_raw"  # 16UC1
    assert m.depth_cameras["camera_depth32"] == "/camera/depth32/image"  # 32FC1
    assert "/camera/depth/compressedDepth" in m.depth_cameras.values()
    assert m.camera_info["cam"] == "/cam/camera_info"  # paired by namespace
    assert m.camera_info["camera_depth"] == "/camera/depth/camera_info"
    assert "/diagnostics" not in m.topics()


def test_json_and_rosbag2(tmp_path: Path) -> None:
    bag = write_ros2(tmp_path / "r2", "sqlite3")
    run = run_inproc("convert", str(bag), "--print-mapping", "--json")
    assert run.returncode == 0, run.stderr
    doc = parse(run.stdout, "convert print-mapping")
    assert doc["mapping"]["state"]["topic"] == "/joint_states" and "state" in doc["guesses"]
    saved = tmp_path / "m.yaml"
    saved.write_text(yaml.safe_dump(doc["mapping"]))
    assert load_mapping(saved).cameras == {"cam": "/cam/image_raw", "cam2": "/cam2/compressed"}


def test_without_a_mapping_convert_points_at_print_mapping(tmp_path: Path) -> None:
    bag = write_plain_mcap(tmp_path / "p.mcap")
    run = run_inproc("convert", str(bag), str(tmp_path / "out"))
    lines = run.stderr.strip().splitlines()
    assert run.returncode == 2 and len(lines) == 1 and "--print-mapping" in lines[0], run.stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["DST"], "takes SRC only"),
        (["--mapping", "m.yaml"], "takes SRC only"),
    ],
)
def test_print_mapping_takes_src_only(tmp_path: Path, args: list[str], message: str) -> None:
    bag = write_plain_mcap(tmp_path / "p.mcap")
    run = run_inproc(
        "convert", str(bag), "--print-mapping", *[str(tmp_path / a) if a != "--mapping" else a for a in args]
    )
    assert run.returncode == 2 and message in run.stderr, run.stderr


def test_print_mapping_of_a_non_bag_and_a_missing_dst(tmp_path: Path) -> None:
    run = run_inproc("convert", str(tmp_path), "--print-mapping")
    assert run.returncode == 2 and "--print-mapping applies to bags" in run.stderr, run.stderr
    run = run_inproc("convert", str(write_plain_mcap(tmp_path / "p.mcap")))
    assert run.returncode == 2 and "DST: missing" in run.stderr, run.stderr
