"""`record --format`: MCAP alone or together with LeRobot v3 in one pass, checked by three MCAP readers."""

from __future__ import annotations

from pathlib import Path

import pytest

from openral_data.formats.mcap import finished_bags
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from tests.support.cli import run_cli
from tests.support.lerobot import verify_mock_dataset
from tests.support.mcap import chunk_compressions
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


def _messages(root: Path) -> list[list[tuple[str, int, bytes]]]:
    """Each bag's (topic, ns after the bag's first message, raw CDR) in log order; the wall-clock stamp of a
    message header (bytes 4..12 of its CDR, after the encapsulation) is zeroed: it is the recording's clock."""
    from rosbags.highlevel import AnyReader

    out = []
    for bag in finished_bags(root):
        with AnyReader([bag]) as reader:
            msgs = [(conn, ns, bytes(raw)) for conn, ns, raw in reader.messages()]
        first = msgs[0][1]
        stamped = ("sensor_msgs/msg/JointState", "sensor_msgs/msg/Image", "sensor_msgs/msg/CompressedImage")
        out.append(
            [
                (c.topic, ns - first, raw[:4] + bytes(8) + raw[12:] if c.msgtype in stamped else raw)
                for c, ns, raw in msgs
            ]
        )
    return out


@pytest.mark.slow
def test_mcap_chunks_are_zstd_by_default_and_hold_the_same_messages(project: Path, tmp_path: Path) -> None:
    import yaml

    scene = write_yaml(tmp_path / "s.yaml", mock_scene(success_after=[6, 3], n_episodes=2))
    outs: dict[str, Path] = {}
    for compression in ("default", "lz4", "none"):
        out = outs[compression] = tmp_path / compression
        extra = [] if compression == "default" else ["--mcap-compression", compression]
        args = ["--scene", str(scene), "--out", str(out), "--format", "mcap", "--image-format", "png", *extra]
        proc = run_cli("record", *args)
        assert proc.returncode == 0, proc.stderr
        assert verify_mock_bags(out / "mcap", image_format="png") == [6, 3]  # rosbags, mcap CRCs, rerun check
    expected = {"default": {"zstd"}, "lz4": {"lz4"}, "none": {""}}
    for name, out in outs.items():
        for bag in finished_bags(out / "mcap"):
            assert chunk_compressions(bag) == expected[name]
            info = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
            # storage-level compression, as rosbag2's MCAP plugin writes it: no file/message compression declared
            assert (info["compression_format"], info["compression_mode"]) == ("", "")
            assert info["storage_identifier"] == "mcap"
    assert _messages(outs["default"] / "mcap") != []
    assert _messages(outs["default"] / "mcap") == _messages(outs["lz4"] / "mcap") == _messages(outs["none"] / "mcap")
    size = {name: sum(p.stat().st_size for p in (out / "mcap").rglob("*.mcap")) for name, out in outs.items()}
    assert size["default"] < size["none"] and size["lz4"] < size["none"]


def test_bad_mcap_compression_is_one_line_error(project: Path, tmp_path: Path) -> None:
    out = tmp_path / "never"
    proc = run_cli("record", "--out", str(out), "--format", "mcap", "--mcap-compression", "gzip")
    assert proc.returncode == 2
    assert proc.stderr.strip() == "error: --mcap-compression: 'gzip' is not one of zstd, lz4, none", proc.stderr
    assert not out.exists()
