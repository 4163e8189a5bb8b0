"""`record --format`: MCAP alone or together with LeRobot v3 in one pass, checked by three MCAP readers."""

from __future__ import annotations

from pathlib import Path

import pytest

from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from tests.support.cli import run_cli
from tests.support.lerobot import verify_mock_dataset
from tests.support.mock_mcap import verify_mock_bags
from tests.support.scenes import mock_scene, write_yaml

LENGTHS = [5, 9, 3]


def test_lerobot_and_mcap_in_one_pass(project: Path, tmp_path: Path) -> None:
    scene = write_yaml(tmp_path / "s.yaml", mock_scene(success_after=LENGTHS, n_episodes=3))
    out = tmp_path / "both"
    summary = record(
        RecordOptions(scene=str(scene), out=out, codec="h264", formats=("lerobot", "mcap"), image_format="jpeg")
    )
    assert [e.length for e in summary.episodes] == LENGTHS
    assert verify_mock_bags(out / "mcap") == LENGTHS
    assert verify_mock_dataset(out, "pyav")["lengths"] == LENGTHS
    assert not (out / "mcap" / ".partial").exists()


@pytest.mark.parametrize("image_format", ["png", "raw"])
def test_mcap_alone_lossless_images(project: Path, tmp_path: Path, image_format: str) -> None:
    scene = write_yaml(tmp_path / "s.yaml", mock_scene(success_after=[4, 2], n_episodes=2))
    out = tmp_path / "m"
    proc = run_cli(
        "record", "--scene", str(scene), "--out", str(out), "--format", "mcap", "--image-format", image_format
    )
    assert proc.returncode == 0, proc.stderr
    assert "formats       mcap" in proc.stdout
    assert verify_mock_bags(out / "mcap", image_format=image_format) == [4, 2]
    assert not (out / "meta").exists()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--format", "lerobot,rosbag"], "--format: unknown format(s) rosbag"),
        (["--format", "mcap,mcap"], "--format: a format is listed twice"),
        (["--format", "mcap", "--image-format", "webp"], "--image-format: 'webp' is not one of"),
    ],
)
def test_bad_format_is_one_line_error(project: Path, tmp_path: Path, args: list[str], message: str) -> None:
    out = tmp_path / "never"
    proc = run_cli("record", "--out", str(out), *args)
    assert proc.returncode == 2
    assert proc.stderr.strip().startswith(f"error: {message}"), proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and not out.exists()
