"""`convert`: real ROS 1 / ROS 2 (sqlite3, mcap) / plain-MCAP logs -> LeRobot v3, checked in lerobot 0.6.1
against the source messages; mapping errors; LeRobot v3 -> MCAP export; our own bags round-trip."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from openral_data.formats.mcap import finished_bags
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from tests.support.bags import MAPPING, WRITERS, expected, write_ros2
from tests.support.cli import run_cli
from tests.support.lerobot import verify_mock_dataset
from tests.support.mcap import chunk_compressions
from tests.support.mock_mcap import verify_mock_bags
from tests.support.scenes import mock_scene, write_yaml

COLOUR_TOL = 4.0


def _load(root: Path) -> object:
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    return LeRobotDataset("local/check", root=root, video_backend="pyav")


@pytest.mark.parametrize("kind", list(WRITERS))
def test_bag_to_lerobot_matches_source_messages(tmp_path: Path, kind: str) -> None:
    bag = WRITERS[kind](tmp_path)
    mapping = write_yaml(tmp_path / "mapping.yaml", MAPPING)
    out = tmp_path / "ds"
    proc = run_cli("convert", str(bag), str(out), "--mapping", str(mapping), "--codec", "h264")
    assert proc.returncode == 0, proc.stderr
    # summary: what was mapped, what was skipped and why
    assert "episodes                               1" in proc.stdout or "episodes " in proc.stdout
    assert "skipped /diagnostics" in proc.stdout and "2 msgs (not in the mapping)" in proc.stdout
    assert "mapped /joint_states" in proc.stdout and "200 msgs" in proc.stdout
    ds = _load(out)
    assert len(ds) == 20  # type: ignore[arg-type]
    assert ds.meta.video_keys == ["observation.images.front", "observation.images.side"]  # type: ignore[attr-defined]
    assert ds.meta.features["observation.state"]["names"] == ["j1", "j2", "j3"]  # type: ignore[attr-defined]
    assert ds.meta.features["action"]["names"] == ["vx", "vy"]  # type: ignore[attr-defined]
    for i in range(len(ds)):  # type: ignore[arg-type]
        item = ds[i]  # type: ignore[index]
        t_ms = int(item["frame_index"]) * 100
        want = expected(t_ms)
        assert item["observation.state"].numpy().tolist() == want["state"], (i, t_ms)
        assert item["action"].numpy().tolist() == want["action"], (i, t_ms)
        assert item["task"] == want["task"]
        for cam in ("front", "side"):
            got = item[f"observation.images.{cam}"].numpy().mean(axis=(1, 2)) * 255.0
            assert np.abs(got - np.array(want[cam])).max() <= COLOUR_TOL, (cam, i, got, want[cam])


def test_split_on_time_gaps_and_nearest(tmp_path: Path) -> None:
    """Two recordings 5 s apart in one bag become two episodes; `nearest` may take the later sample."""
    bag = tmp_path / "two"
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    from tests.support.bags import TYPES, build, samples

    store = get_typestore(Stores.ROS2_HUMBLE)
    with Writer(bag, version=8, storage_plugin=StoragePlugin.MCAP) as writer:
        conns = {topic: writer.add_connection(topic, msgtype, typestore=store) for topic, msgtype in TYPES.items()}
        for offset in (0, 7000):
            for topic, ns, f in samples(duration_ms=2000, offset_ms=offset):
                writer.write(conns[topic], ns, store.serialize_cdr(build(store, topic, ns, f, False), TYPES[topic]))
    mapping = dict(MAPPING, episodes={"split": "gap", "gap": 1.0}, align={"method": "nearest", "max_staleness": 0.1})
    out = tmp_path / "ds"
    proc = run_cli("convert", str(bag), str(out), "--mapping", str(write_yaml(tmp_path / "m.yaml", mapping)),
                   "--codec", "h264")  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    ds = _load(out)
    lengths = [int(x) for x in ds.meta.episodes["length"]]  # type: ignore[attr-defined]
    assert lengths == [20, 20]
    item = ds[3]  # type: ignore[index]
    # frame at 300 ms: nearest /cmd sample is 300 (k=6), nearest camera sample is 330 ms (k=5), not 264 (k=4)
    assert item["action"].numpy().tolist() == [6.0, -6.0]
    got = item["observation.images.front"].numpy().mean(axis=(1, 2)) * 255.0
    assert abs(got[0] - 100) <= COLOUR_TOL


def test_unfillable_frames_are_reported_not_zero_filled(tmp_path: Path) -> None:
    """A camera that stops for 0.5 s: those frames are skipped (the episode splits), never zero-filled."""
    bag = tmp_path / "holes"
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    from tests.support.bags import TYPES, build, samples

    store = get_typestore(Stores.ROS2_HUMBLE)
    with Writer(bag, version=8, storage_plugin=StoragePlugin.SQLITE3) as writer:
        conns = {topic: writer.add_connection(topic, msgtype, typestore=store) for topic, msgtype in TYPES.items()}
        for topic, ns, f in samples():
            t_ms = (ns - 1_700_000_000 * 10**9) // 10**6
            if topic == "/cam/image_raw" and 700 <= t_ms < 1200:
                continue
            writer.write(conns[topic], ns, store.serialize_cdr(build(store, topic, ns, f, False), TYPES[topic]))
    out = tmp_path / "ds"
    proc = run_cli("convert", str(bag), str(out), "--mapping", str(write_yaml(tmp_path / "m.yaml", MAPPING)),
                   "--codec", "h264")  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    # camera samples around the hole: 660 then 1254 ms; frames 800..1200 have none within 100 ms -> skipped
    assert "5 skipped, never zero-filled (1 episode split(s)" in proc.stdout, proc.stdout
    assert "Image: 23 msgs, 15 used, 8 unused (superseded or outside every frame), 5 frames unfillable" in proc.stdout
    ds = _load(out)
    assert [int(x) for x in ds.meta.episodes["length"]] == [8, 7]  # type: ignore[attr-defined]
    for i in range(len(ds)):  # type: ignore[arg-type]
        item = ds[i]  # type: ignore[index]
        t_ms = int(item["frame_index"]) * 100 + (1300 if int(item["episode_index"]) == 1 else 0)
        assert item["observation.state"].numpy().tolist() == expected(t_ms)["state"]


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"fps": 0}, "m.yaml: fps: Input should be greater than 0"),
        ({"colour": 1}, "m.yaml: colour: unknown key"),
        ({"state": {"topic": "/joint_states", "joints": ["j1", "j1"]}}, "m.yaml: state: joints must"),
        ({"task": "x"}, "set exactly one of task"),
        ({"cameras": {"front": "/nope"}}, "mapped topic(s) /nope not in the bag"),
        ({"state": {"topic": "/joint_states", "joints": ["j1", "j9"]}}, "joints ['j9'] not in the message's names"),
        ({"action": {"topic": "/cmd", "field": "layout.nothing"}}, "message has no field 'layout.nothing'"),
    ],
)
def test_mapping_errors_are_one_line(tmp_path: Path, change: dict[str, object], message: str) -> None:
    bag = write_ros2(tmp_path / "b", "mcap", duration_ms=300)
    mapping = write_yaml(tmp_path / "m.yaml", {**MAPPING, **change})
    out = tmp_path / "ds"
    proc = run_cli("convert", str(bag), str(out), "--mapping", str(mapping), "--codec", "h264")
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and message in lines[0], proc.stderr
    assert not out.exists()


def test_refuses_non_empty_dst_and_unknown_src(tmp_path: Path) -> None:
    dst = tmp_path / "full"
    dst.mkdir()
    (dst / "keep.txt").write_text("mine")
    proc = run_cli("convert", str(tmp_path / "missing.bag"), str(tmp_path / "x"))
    assert proc.returncode == 2 and "missing.bag: no such file or directory" in proc.stderr
    bag = write_ros2(tmp_path / "b", "mcap", duration_ms=300)
    proc = run_cli("convert", str(bag), str(dst), "--mapping", str(write_yaml(tmp_path / "m.yaml", MAPPING)))
    assert proc.returncode == 2 and "DST exists and is not empty" in proc.stderr
    assert (dst / "keep.txt").read_text() == "mine"
    proc = run_cli("convert", str(bag), str(tmp_path / "y"))
    assert proc.returncode == 2 and "not written by openral-data" in proc.stderr and "--mapping" in proc.stderr


def test_record_mcap_then_convert_round_trip(project: Path, tmp_path: Path) -> None:
    """record --format mcap (lossless png) -> convert without a mapping -> the mock's values in lerobot."""
    scene = write_yaml(tmp_path / "s.yaml", mock_scene(success_after=[6, 4, 8], n_episodes=3))
    rec = tmp_path / "rec"
    record(RecordOptions(scene=str(scene), out=rec, formats=("mcap",), image_format="png"))
    out = tmp_path / "ds"
    proc = run_cli("convert", str(rec / "mcap"), str(out), "--codec", "h264")
    assert proc.returncode == 0, proc.stderr
    assert "mapped /reward" in proc.stdout
    seen = verify_mock_dataset(out, "pyav")
    assert seen["lengths"] == [6, 4, 8]
    from openral_data.formats.lerobot_v3.reader import read_episodes

    assert read_episodes(out).column("openral.success").to_pylist() == [True, True, True]
    # outcomes round-trip exactly: the mock's reward is 1.0 on the (successful, terminal) last step only
    import pyarrow.parquet as pq

    frames = pq.read_table(out / "data").sort_by("index")
    last = [i == n - 1 for n in (6, 4, 8) for i in range(n)]
    assert frames.column("next.reward").to_pylist() == [float(x) for x in last]
    assert frames.column("next.done").to_pylist() == last
    assert frames.column("next.success").to_pylist() == last


def test_lerobot_to_mcap_selected_episodes(project: Path, tmp_path: Path) -> None:
    scene = write_yaml(tmp_path / "s.yaml", mock_scene(success_after=[3, 5, 4, 6], n_episodes=4))
    ds = tmp_path / "ds"
    record(RecordOptions(scene=str(scene), out=ds, codec="h264"))
    out = tmp_path / "bags"
    proc = run_cli("convert", str(ds), str(out), "--episodes", "1,3")
    assert proc.returncode == 0, proc.stderr
    assert sorted(p.name for p in out.iterdir()) == ["episode_000001", "episode_000003"]
    # the bags hold the dataset's values: rename to 0.. and reuse the mock checker on each single bag
    for e in (1, 3):
        single = tmp_path / f"one_{e}"
        single.mkdir()
        (out / f"episode_{e:06d}").rename(single / "episode_000000")
        _check_exported(single, e)
    proc = run_cli("convert", str(ds), str(tmp_path / "bad"), "--episodes", "2,9")
    assert proc.returncode == 2 and "--episodes: '9' is outside the dataset's episodes 0..3" in proc.stderr


def _check_exported(root: Path, episode: int) -> None:
    from tests.support.mcap import check_bag

    topics = check_bag(root / "episode_000000")
    start = json.loads(topics["/openral/episode"][0][1].data)
    assert start["episode"] == episode
    states = topics["/joint_states"]
    for t, (_, js) in enumerate(states):
        assert js.position[0] == t and js.position[1] == episode
    from openral_data.formats.mcap.messages import decode_image

    for t, (_, msg) in enumerate(topics["/camera/front/image/compressed"]):
        rgb = decode_image(msg, "sensor_msgs/msg/CompressedImage").reshape(-1, 3).mean(axis=0)
        assert np.abs(rgb - np.array([t, episode, 128])).max() <= 2 * COLOUR_TOL  # h264 then jpeg


def test_export_all_matches_verify_mock_bags(project: Path, tmp_path: Path) -> None:
    scene = write_yaml(tmp_path / "s.yaml", mock_scene(success_after=[3, 4], n_episodes=2))
    ds = tmp_path / "ds"
    record(RecordOptions(scene=str(scene), out=ds, codec="h264"))
    out = tmp_path / "bags"
    proc = run_cli("convert", str(ds), str(out), "--image-format", "raw")
    assert proc.returncode == 0, proc.stderr
    assert "not exported" in proc.stdout
    assert verify_mock_bags(out, image_format="raw", tolerance=COLOUR_TOL) == [3, 4]  # h264-decoded pixels
    assert [chunk_compressions(b) for b in finished_bags(out)] == [{"zstd"}, {"zstd"}]  # the default
    plain = tmp_path / "plain"
    proc = run_cli("convert", str(ds), str(plain), "--image-format", "raw", "--mcap-compression", "none")
    assert proc.returncode == 0, proc.stderr
    assert verify_mock_bags(plain, image_format="raw", tolerance=COLOUR_TOL) == [3, 4]
    assert [chunk_compressions(b) for b in finished_bags(plain)] == [{""}, {""}]
