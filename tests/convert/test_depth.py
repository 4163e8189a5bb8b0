"""`convert` with depth cameras (16UC1 millimetres, 32FC1 metres) and CameraInfo topics: lerobot 0.6.1 loads the
depth videos within one quantization step of the source messages, invalid pixels load as depth_min / depth_max,
the intrinsics are the CameraInfo's; doctor --deep is healthy; view and LeRobot -> MCAP handle depth features."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from tests.support.bags import (
    DEPTH_MAPPING,
    camera_info,
    compressed_depth,
    depth_mm,
    expected,
    write_plain_mcap,
    write_ros1,
    write_ros2,
)
from tests.support.cli import run_cli
from tests.support.mcap import check_bag
from tests.support.scenes import write_yaml
from tests.viz.test_rerun_view import column

DEPTH_MIN, DEPTH_MAX, SHIFT = 0.01, 10.0, 3.5  # lerobot's DepthEncoderConfig defaults (metres)
WRITE = {
    "ros1": lambda d: write_ros1(d / "log.bag", depth=True),
    "ros2-mcap": lambda d: write_ros2(d / "log_mcap", "mcap", depth=True),
    "plain-mcap": lambda d: write_plain_mcap(d / "log.mcap", depth=True),
}


def step_mm(depth_mm: np.ndarray[Any, Any], use_log: bool = True) -> np.ndarray[Any, Any]:
    """One quantization step (mm) at each source depth: the code spacing of the 12-bit log (or linear) map."""
    if not use_log:
        return np.full(depth_mm.shape, (DEPTH_MAX - DEPTH_MIN) * 1000 / 4095)
    delta = (math.log(DEPTH_MAX + SHIFT) - math.log(DEPTH_MIN + SHIFT)) / 4095
    return (depth_mm + SHIFT * 1000) * (math.exp(delta) - 1)


def check_depth(got_mm: np.ndarray[Any, Any], src_mm: np.ndarray[Any, Any], where: object) -> None:
    """Every pixel within one step (+ the loader's 1 mm rounding); invalid / out-of-range ones clipped."""
    low, high = src_mm < DEPTH_MIN * 1000, src_mm > DEPTH_MAX * 1000
    low |= np.isnan(src_mm)  # NaN (no return) and -inf load as depth_min, +inf as depth_max
    assert (got_mm[low] == DEPTH_MIN * 1000).all(), where
    assert (got_mm[high] == DEPTH_MAX * 1000).all(), where
    ok = ~(low | high)
    err = np.abs(got_mm[ok] - src_mm[ok])
    assert (err <= step_mm(src_mm[ok]) + 0.5).all(), (where, float((err - step_mm(src_mm[ok])).max()))


def _convert(tmp_path: Path, bag: Path, mapping: dict[str, Any]) -> Path:
    out = tmp_path / "ds"
    proc = run_cli(
        "convert", str(bag), str(out), "--mapping", str(write_yaml(tmp_path / "m.yaml", mapping)), "--codec", "h264"
    )
    assert proc.returncode == 0, proc.stderr
    return out


@pytest.mark.slow
@pytest.mark.parametrize("kind", list(WRITE))
def test_depth_cameras_load_in_lerobot_within_one_step(tmp_path: Path, kind: str) -> None:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    out = _convert(tmp_path, WRITE[kind](tmp_path), DEPTH_MAPPING)
    ds = LeRobotDataset("local/check", root=out, video_backend="pyav")
    assert sorted(ds.meta.depth_keys) == ["observation.images.depth", "observation.images.depth32"]
    feats = ds.meta.features
    for key, unit in (("observation.images.depth", "mm"), ("observation.images.depth32", "m")):
        info = feats[key]["info"]
        assert tuple(feats[key]["shape"]) == (48, 64, 1)
        assert info["is_depth_map"] is True and info["depth_unit"] == unit
        assert (info["video.codec"], info["video.pix_fmt"], info["video.channels"]) == ("hevc", "gray12le", 1)
        assert (info["video.depth_min"], info["video.depth_max"], info["video.shift"]) == (DEPTH_MIN, DEPTH_MAX, SHIFT)
        assert info["video.use_log"] is True
    # intrinsics: the CameraInfo messages', for a depth and a colour camera; none where no topic was mapped
    assert feats["observation.images.depth"]["info"]["camera_info"] == camera_info("/camera/depth/camera_info")
    assert feats["observation.images.front"]["info"]["camera_info"] == camera_info("/cam/camera_info")
    assert "camera_info" not in feats["observation.images.depth32"]["info"]
    assert len(ds) == 20
    sources_mm, sources_m = [], []
    for i in range(len(ds)):
        item = ds[i]
        want = expected(int(item["frame_index"]) * 100)
        sources_mm.append(want["depth"])
        sources_m.append(want["depth32"])
        got = item["observation.images.depth"].numpy()[0]  # lerobot returns (1, H, W) float millimetres
        check_depth(got, want["depth"].astype(np.float64), ("16UC1", i))
        got32 = item["observation.images.depth32"].numpy()[0]
        check_depth(got32, want["depth32"].astype(np.float64) * 1000, ("32FC1", i))
    # stats: of the source frames, in depth_unit, over finite pixels, shape (1, 1, 1)
    stats = json.loads((out / "meta/stats.json").read_text())
    for key, frames in (("observation.images.depth", sources_mm), ("observation.images.depth32", sources_m)):
        px = np.stack(frames).astype(np.float64)
        px = px[np.isfinite(px)]
        s = stats[key]
        assert s["count"] == [20]
        assert np.asarray(s["mean"]).shape == (1, 1, 1)
        assert s["min"][0][0][0] == pytest.approx(px.min()) and s["max"][0][0][0] == pytest.approx(px.max())
        assert s["mean"][0][0][0] == pytest.approx(px.mean()) and s["std"][0][0][0] == pytest.approx(px.std())
        bin_width = 1.0 if key.endswith("depth") else 0.001
        for q, v in (("q01", 0.01), ("q50", 0.5), ("q99", 0.99)):
            assert abs(s[q][0][0][0] - np.quantile(px, v)) <= bin_width, (key, q)
    proc = run_cli("doctor", str(out), "--deep")
    assert proc.returncode == 0 and "healthy" in proc.stdout, proc.stdout + proc.stderr


def test_linear_quantization_setting(tmp_path: Path) -> None:
    """`depth: {use_log: false, depth_max: 5}`: lerobot reads the settings back from info and decodes with them."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    mapping = dict(DEPTH_MAPPING, depth={"use_log": False, "depth_max": 5.0}, camera_info={})
    mapping["depth_cameras"] = {"depth": "/camera/depth/image_rect_raw"}
    out = _convert(tmp_path, write_ros2(tmp_path / "b", "mcap", depth=True, duration_ms=500), mapping)
    ds = LeRobotDataset("local/check", root=out, video_backend="pyav")
    info = ds.meta.features["observation.images.depth"]["info"]
    assert (info["video.use_log"], info["video.depth_max"]) == (False, 5.0)
    step = (5.0 - DEPTH_MIN) * 1000 / 4095
    for i in range(len(ds)):
        item = ds[i]
        src = expected(int(item["frame_index"]) * 100)["depth"].astype(np.float64)
        got = item["observation.images.depth"].numpy()[0]
        ok = (src >= DEPTH_MIN * 1000) & (src <= 5000)
        assert (np.abs(got[ok] - src[ok]) <= step + 0.5).all()
        assert (got[src > 5000] == 5000).all() and (got[src < 10] == 10).all()


def _refused(tmp_path: Path, mapping: dict[str, Any], bag: Path | None = None) -> str:
    bag = bag or write_ros2(tmp_path / "b", "mcap", depth=True, duration_ms=300)
    out = tmp_path / "ds"
    proc = run_cli("convert", str(bag), str(out), "--mapping", str(write_yaml(tmp_path / "m.yaml", mapping)))
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), proc.stderr
    assert not out.exists()
    return lines[0]


def test_camera_info_of_another_size_is_one_line(tmp_path: Path) -> None:
    mapping = dict(DEPTH_MAPPING, camera_info={"front": "/camera/depth/camera_info"})
    line = _refused(tmp_path, mapping)
    assert line.endswith(
        "mapping: camera_info.front (/camera/depth/camera_info): CameraInfo is 64x48 but the camera's images are 32x24"
    ), line


def test_depth_camera_on_a_colour_topic_is_one_line(tmp_path: Path) -> None:
    line = _refused(
        tmp_path,
        dict(
            DEPTH_MAPPING, cameras={"side": "/cam2/compressed"}, depth_cameras={"d": "/cam/image_raw"}, camera_info={}
        ),
    )
    assert line.endswith(
        "mapping: depth_cameras.d (/cam/image_raw): encoding 'rgb8' is not a depth encoding "
        "(a depth camera needs 16UC1 or 32FC1)"
    ), line


def test_compressed_depth_of_another_format_is_one_line(tmp_path: Path) -> None:
    mapping = dict(DEPTH_MAPPING, cameras={"front": "/cam/image_raw"}, depth_cameras={"d": "/cam2/compressed"})
    line = _refused(tmp_path, dict(mapping, camera_info={}))
    assert line.endswith(
        "mapping: depth_cameras.d (/cam2/compressed): CompressedImage format 'png' is not supported for depth "
        "(a depth camera needs a 16UC1/32FC1 Image, or compressedDepth png)"
    ), line


def test_camera_info_topic_of_another_type_is_one_line(tmp_path: Path) -> None:
    line = _refused(tmp_path, dict(DEPTH_MAPPING, camera_info={"depth": "/task"}))
    assert line.endswith(
        "mapping: camera_info.depth (/task): the topic carries std_msgs/msg/String, not sensor_msgs/msg/CameraInfo"
    ), line


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"camera_info": {"nope": "/cam/camera_info"}}, "camera_info.nope: no camera or depth camera of that name"),
        ({"depth_cameras": {"front": "/camera/depth32/image"}}, "'front' is in both cameras and depth_cameras"),
        ({"depth": {"depth_min": 2.0, "depth_max": 1.0}}, "depth_max (1.0) must be above depth_min (2.0)"),
        ({"depth": {"shift": -1.0}}, "use_log needs depth_min + shift > 0"),
        ({"depth_cameras": {"d": "/cam/image_raw"}}, "two cameras map the same topic"),
    ],
)
def test_mapping_mistakes(tmp_path: Path, change: dict[str, Any], message: str) -> None:
    bag = write_ros2(tmp_path / "b", "mcap", depth=True, duration_ms=100)
    line = _refused(tmp_path, {**DEPTH_MAPPING, **change}, bag)
    assert message in line, line


def test_view_export_and_round_trip_of_a_depth_dataset(tmp_path: Path) -> None:
    """`view --save` logs each depth camera as one DepthImage per frame (mm, as lerobot loads it). LeRobot -> MCAP
    writes each depth camera as a 16UC1 Image topic (what lerobot loads, in mm) and the intrinsics as CameraInfo
    topics; converting that MCAP back (no mapping) gives depth features that load exactly as the first dataset's,
    with the same quantizer and intrinsics (a 32FC1 camera comes back in mm)."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    out = _convert(tmp_path, write_ros2(tmp_path / "b", "mcap", depth=True, duration_ms=500), DEPTH_MAPPING)
    rrd = tmp_path / "v.rrd"
    proc = run_cli("view", str(out), "--save", str(rrd))
    assert proc.returncode == 0, proc.stderr
    buffers = column(rrd, "/cameras/depth", "DepthImage:buffer")
    assert len(buffers) == 5
    for k, buf in enumerate(buffers):  # frame k at 100 ms: the 16UC1 message k * 100 // 66
        got = np.asarray(buf, dtype=np.uint8).view(np.uint16).reshape(48, 64)
        check_depth(got.astype(np.float64), depth_mm(k * 100 // 66).astype(np.float64), ("view", k))
    ds = LeRobotDataset("local/check", root=out, video_backend="pyav")
    loaded = {
        cam: [ds[i][f"observation.images.{cam}"].numpy()[0] for i in range(len(ds))] for cam in ("depth", "depth32")
    }
    mc = tmp_path / "mc"
    proc = run_cli("convert", str(out), str(mc), "--json")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["not_exported"] == []
    topics = check_bag(mc / "episode_000000")  # rosbags, mcap CRCs and `rerun mcap check` accept the bag
    for cam in ("depth", "depth32"):
        msgs = [msg for _, msg in topics[f"/camera/{cam}/depth/image_raw"]]
        assert [(x.encoding, x.height, x.width) for x in msgs] == [("16UC1", 48, 64)] * 5
        for msg, want in zip(msgs, loaded[cam], strict=True):
            got = np.frombuffer(bytes(msg.data), "<u2").reshape(48, 64).astype(np.float64)
            assert np.abs(got - want).max() <= 1, cam
    for cam, topic in (("depth", "/camera/depth/camera_info"), ("front", "/cam/camera_info")):
        ((_, msg),) = topics[f"/camera/{cam}/camera_info"]
        want = camera_info(topic)
        assert (msg.header.frame_id, msg.width, msg.height) == (want["frame_id"], want["width"], want["height"])
        assert msg.k.tolist() == want["k"] and msg.d.tolist() == want["d"] and msg.p.tolist() == want["p"]
    back = tmp_path / "back"
    proc = run_cli("convert", str(mc), str(back), "--codec", "h264")
    assert proc.returncode == 0, proc.stderr
    ds2 = LeRobotDataset("local/back", root=back, video_backend="pyav")
    f1, f2 = ds.meta.features, ds2.meta.features
    assert f2["observation.images.depth"]["info"] == f1["observation.images.depth"]["info"]
    assert f2["observation.images.front"]["info"]["camera_info"] == camera_info("/cam/camera_info")
    assert f2["observation.images.depth32"]["info"]["depth_unit"] == "mm"
    for i in range(len(ds2)):
        for cam in ("depth", "depth32"):
            assert np.array_equal(ds2[i][f"observation.images.{cam}"].numpy()[0], loaded[cam][i]), (cam, i)


def test_lerobot_written_depth_dataset(tmp_path: Path) -> None:
    """A depth video written by lerobot 0.6.1 itself: doctor --deep healthy; `view` shows the depth lerobot's loader
    returns (±1 mm rounding); LeRobot -> MCAP exports it as a 16UC1 topic."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    from tests.support.lerobot_written import DEPTH_CAMERA, LENGTHS, write_lerobot_dataset

    root = tmp_path / "lr"
    write_lerobot_dataset(root, False, depth_camera=True)
    proc = run_cli("doctor", str(root), "--deep")
    assert proc.returncode == 0 and "healthy" in proc.stdout, proc.stdout + proc.stderr
    rrd = tmp_path / "v.rrd"
    proc = run_cli("view", str(root), "--episode", "1", "--save", str(rrd))
    assert proc.returncode == 0, proc.stderr
    buffers = column(rrd, "/cameras/depth", "DepthImage:buffer")
    assert len(buffers) == LENGTHS[1]
    ds = LeRobotDataset("local/check", root=root, video_backend="pyav")
    for t, buf in enumerate(buffers):
        got = np.asarray(buf, dtype=np.uint8).view(np.uint16).reshape(32, 48).astype(np.int64)
        want = ds[LENGTHS[0] + t][DEPTH_CAMERA].numpy()[0].astype(np.int64)
        assert np.abs(got - want).max() <= 1, t
    proc = run_cli("convert", str(root), str(tmp_path / "mc"), "--json")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["not_exported"] == []
    from rosbags.highlevel import AnyReader

    with AnyReader([tmp_path / "mc/episode_000001"]) as reader:
        assert {c.topic: c.msgcount for c in reader.connections}["/camera/depth/depth/image_raw"] == LENGTHS[1]


def test_compressed_depth_topics(tmp_path: Path) -> None:
    """image_transport's compressedDepth (16UC1 PNG; 32FC1 as quantized inverse depth) as depth cameras: lerobot
    loads them within one step of what the messages decode to."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    mapping = dict(
        DEPTH_MAPPING,
        depth_cameras={"cd": "/camera/depth/compressedDepth", "cd32": "/camera/depth32/compressedDepth"},
        camera_info={},
    )
    out = _convert(tmp_path, write_plain_mcap(tmp_path / "b.mcap", depth=True, duration_ms=600), mapping)
    ds = LeRobotDataset("local/check", root=out, video_backend="pyav")
    info = ds.meta.features
    assert info["observation.images.cd"]["info"]["depth_unit"] == "mm"
    assert info["observation.images.cd32"]["info"]["depth_unit"] == "m"
    for i in range(len(ds)):
        item = ds[i]
        want = expected(int(item["frame_index"]) * 100)
        check_depth(item["observation.images.cd"].numpy()[0], want["depth"].astype(np.float64), ("cd", i))
        src32 = compressed_depth(want["depth32"])[1].astype(np.float64) * 1000
        check_depth(item["observation.images.cd32"].numpy()[0], src32, ("cd32", i))


def test_two_episodes_share_one_depth_video(tmp_path: Path) -> None:
    """Two bags -> two episodes whose depth videos are joined into one mp4 without re-encoding; lerobot decodes
    the second episode's depth from the joined file within one step."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    src = tmp_path / "bags"
    src.mkdir()
    write_ros2(src / "a", "mcap", depth=True, duration_ms=700)
    write_ros2(src / "b", "mcap", depth=True, duration_ms=900)
    mapping = dict(DEPTH_MAPPING, depth_cameras={"depth": "/camera/depth/image_rect_raw"}, camera_info={})
    out = _convert(tmp_path, src, mapping)
    ds = LeRobotDataset("local/check", root=out, video_backend="pyav")
    assert [int(n) for n in ds.meta.episodes["length"]] == [7, 9]
    assert float(ds.meta.episodes["videos/observation.images.depth/from_timestamp"][1]) == pytest.approx(0.7)
    assert len(list((out / "videos/observation.images.depth").rglob("*.mp4"))) == 1
    for i in range(len(ds)):
        item = ds[i]
        want = expected(int(item["frame_index"]) * 100)["depth"].astype(np.float64)
        check_depth(item["observation.images.depth"].numpy()[0], want, ("two", i))
    # doctor --deep compares each episode's decoded depth with its stored mean: moved by 500 mm, episode 1 is caught
    from openral_data.doctor import check

    assert check(out, deep=True) == []
    path = next((out / "meta/episodes").rglob("*.parquet"))
    table = pq.read_table(path)
    col = "stats/observation.images.depth/mean"
    means = table[col].to_pylist()
    means[1] = [[[means[1][0][0][0] + 500.0]]]
    table = table.set_column(table.schema.get_field_index(col), col, pa.array(means, type=table.schema.field(col).type))
    pq.write_table(table, path)
    content = [f for f in check(out, deep=True) if f.code == "video.content"]
    assert len(content) == 1 and "episode(s) [1]" in content[0].message, content
