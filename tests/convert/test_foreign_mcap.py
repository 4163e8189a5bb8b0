"""MCAP that is not ROS 2 (Foxglove's SDK with its protobuf schemas, the `mcap` library's JSON channels with a
jsonschema, `mcap_ros1`'s ROS 1 messages) converts with no mapping written: its well-known schemas mapped by
default, every value equal to what mcap's own reader (make_reader + the decoder factories, JSON by json.loads)
decodes for the frame's time, the cameras upright, the frames on the fps grid; `info` and `--print-mapping` read
it; a mapping can name JSON fields."""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import av
import numpy as np
import numpy.typing as npt
import pyarrow.parquet as pq
import pytest
from mcap.decoder import DecoderFactory
from mcap.reader import make_reader
from mcap.records import Schema

from tests.support.foreign_mcap import (
    BAND,
    FRAMES,
    STEP,
    T0,
    joint_positions,
    write_cdr_without_profile,
    write_foxglove,
    write_foxglove_lists,
    write_json,
    write_ros1_mcap,
)
from tests.support.inproc import run_inproc

# a real third-party file (never committed): ../shared/fixtures/<name>/ beside the checkout, or $OPENRAL_REAL_MCAP
REAL = Path(os.environ.get("OPENRAL_REAL_MCAP") or Path(__file__).resolve().parents[3] / "shared" / "fixtures")
REAL /= "cartpole_jsonschema"


def _decoded(path: Path) -> dict[str, list[tuple[int, Any]]]:
    """Every message as mcap's own reader decodes it: protobuf and ROS 1 by their decoder factories, JSON by
    json.loads; per topic, (log time, message) in log-time order."""
    from mcap_protobuf.decoder import DecoderFactory as Protobuf
    from mcap_ros1.decoder import DecoderFactory as Ros1
    from mcap_ros2.decoder import DecoderFactory as Ros2

    out: dict[str, list[tuple[int, Any]]] = {}
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[Protobuf(), Ros1(), Ros2(), _Json()])
        for _, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True):
            out.setdefault(channel.topic, []).append((message.log_time, decoded))
    return out


class _Json(DecoderFactory):
    def decoder_for(self, message_encoding: str, schema: Schema | None) -> Callable[[bytes], Any] | None:
        return json.loads if message_encoding == "json" else None


def _convert(src: Path, out: Path, *extra: str) -> dict[str, Any]:
    run = run_inproc("convert", str(src), str(out), "--codec", "h264", "--json", *extra)
    assert run.returncode == 0, run.stderr
    doc: dict[str, Any] = json.loads(run.stdout)
    return doc


def _rows(root: Path) -> dict[str, list[Any]]:
    return pq.read_table(sorted((root / "data").rglob("*.parquet"))[0]).to_pydict()


def _frame_times(root: Path, rows: dict[str, list[Any]]) -> list[int]:
    """The frames' times on the grid (the first message's time + k / fps), checked against the timestamp column."""
    fps = json.loads((root / "meta/info.json").read_text())["fps"]
    times = [T0 + round(k * 1e9 / fps) for k in range(len(rows["frame_index"]))]
    np.testing.assert_allclose(rows["timestamp"], [(t - T0) / 1e9 for t in times], atol=1e-6)
    return times


def _at(messages: list[tuple[int, Any]], t: int) -> Any:
    """The latest message at or before `t` (align.method previous)."""
    return [m for ns, m in messages if ns <= t][-1]


def _f32(values: Any) -> npt.NDArray[np.float32]:
    return np.asarray(values, np.float32)


def _video(root: Path, camera: str) -> list[npt.NDArray[np.uint8]]:
    path = sorted((root / "videos" / f"observation.images.{camera}").rglob("*.mp4"))[0]
    with av.open(str(path)) as container:
        frames: list[npt.NDArray[np.uint8]] = [
            f.to_ndarray(format="rgb24")  # type: ignore[misc]
            for f in container.decode(container.streams.video[0])
        ]
    return frames


def _upright(frame: npt.NDArray[np.uint8], flipped: bool = False) -> None:
    top, bottom = frame[: BAND - 2].reshape(-1, 3).mean(axis=0), frame[-BAND + 2 :].reshape(-1, 3).mean(axis=0)
    red, blue = (bottom, top) if flipped else (top, bottom)
    assert red[0] > 200 and red[2] < 60 and blue[2] > 200 and blue[0] < 60, (top, bottom)


def test_foxglove_protobuf_converts_with_no_mapping(tmp_path: Path) -> None:
    src = write_foxglove(tmp_path / "fox.mcap")
    info = run_inproc("info", str(src), "--json")
    assert info.returncode == 0, info.stderr
    types = {t["topic"]: (t["type"], t["messages"]) for t in json.loads(info.stdout)["topics"]}
    assert types["/cam"] == ("foxglove.CompressedImage", FRAMES) and types["/tf"] == ("foxglove.FrameTransform", FRAMES)
    doc = _convert(src, tmp_path / "out")
    root = tmp_path / "out"
    rows = _rows(root)
    times = _frame_times(root, rows)
    assert doc["frames"] == len(times) >= FRAMES
    got = _decoded(src)
    for k, t in enumerate(times):
        tf, gps, cmd = _at(got["/tf"], t), _at(got["/gps"], t), _at(got["/cmd/pose"], t).pose
        state = [tf.translation.x, tf.translation.y, tf.translation.z, tf.rotation.x, tf.rotation.y, tf.rotation.z,
                 tf.rotation.w, gps.latitude, gps.longitude, gps.altitude]  # fmt: skip
        action = [cmd.position.x, cmd.position.y, cmd.position.z,
                  cmd.orientation.x, cmd.orientation.y, cmd.orientation.z, cmd.orientation.w]  # fmt: skip
        np.testing.assert_array_equal(rows["observation.state"][k], _f32(state))
        np.testing.assert_array_equal(rows["action"][k], _f32(action))
    info_json = json.loads((root / "meta/info.json").read_text())
    assert info_json["features"]["observation.state"]["names"][:2] == ["gripper.x", "gripper.y"]
    cam, wrist = _video(root, "cam"), _video(root, "wrist")
    assert len(cam) == len(wrist) == len(times)
    for k in (0, len(times) - 1):
        _upright(cam[k])
        _upright(wrist[k], flipped=True)  # the RawImage holds the picture upside down, as written
        i = (times[k] - T0) // STEP
        assert abs(float(cam[k][BAND + 2 : -BAND - 2].mean()) - 8 * i) < 6  # the frame's own picture


def test_foxglove_transforms_poses_and_depth(tmp_path: Path) -> None:
    """FrameTransforms and PosesInFrame: every transform / pose of a message, 7 numbers each, named by child frame;
    a 16UC1 RawImage: a depth camera."""
    src = write_foxglove_lists(tmp_path / "lists.mcap")
    _convert(src, tmp_path / "out")
    rows = _rows(tmp_path / "out")
    got = _decoded(src)
    for k, t in enumerate(_frame_times(tmp_path / "out", rows)):
        tf, poses = _at(got["/tf"], t).transforms, _at(got["/poses"], t).poses
        want = [v for f in tf for v in (f.translation.x, f.translation.y, f.translation.z, f.rotation.x,
                                        f.rotation.y, f.rotation.z, f.rotation.w)]  # fmt: skip
        want += [v for p in poses for v in (p.position.x, p.position.y, p.position.z, p.orientation.x,
                                            p.orientation.y, p.orientation.z, p.orientation.w)]  # fmt: skip
        np.testing.assert_array_equal(rows["observation.state"][k], _f32(want))
    features = json.loads((tmp_path / "out/meta/info.json").read_text())["features"]
    assert features["observation.state"]["names"][:8] == ["a.x", "a.y", "a.z", "a.qx", "a.qy", "a.qz", "a.qw", "b.x"]
    assert features["observation.images.depth"]["info"]["depth_unit"] == "mm"


def test_json_channels_convert_with_no_mapping_and_by_named_fields(tmp_path: Path) -> None:
    src = write_json(tmp_path / "j.mcap")
    printed = run_inproc("convert", str(src), "--print-mapping", "--json")
    assert printed.returncode == 0, printed.stderr
    guessed = json.loads(printed.stdout)["mapping"]
    assert guessed["state"] == {"topic": "/joints", "field": "position", "joints": ["j1", "j2", "j3"]}
    assert guessed["cameras"] == {"camera": "/camera"}
    _convert(src, tmp_path / "out")
    rows = _rows(tmp_path / "out")
    times = _frame_times(tmp_path / "out", rows)
    got = _decoded(src)
    for k, t in enumerate(times):
        joints, command = _at(got["/joints"], t), _at(got["/command"], t)
        np.testing.assert_array_equal(rows["observation.state"][k], _f32(joints["position"]))
        np.testing.assert_array_equal(rows["action"][k], _f32([command["gripper"], *command["velocity"]]))
    _upright(_video(tmp_path / "out", "camera")[0])
    # a mapping naming JSON fields, aligned on the messages' own timestamps
    mapping = tmp_path / "m.yaml"
    mapping.write_text(json.dumps({
        "fps": 10, "task": "t", "state": {"topic": "/joints", "field": "position", "joints": ["j3", "j1"]},
        "action": {"topic": "/command", "field": "velocity", "names": ["vx", "vy"]},
        "align": {"clock": "header", "method": "nearest", "max_staleness": 0.01},
    }))  # fmt: skip
    doc = _convert(src, tmp_path / "named", "--mapping", str(mapping))
    rows = _rows(tmp_path / "named")
    assert doc["frames"] == FRAMES
    np.testing.assert_array_equal(rows["observation.state"], _f32([joint_positions(i)[::-2] for i in
                                                                         range(FRAMES)]))  # fmt: skip
    np.testing.assert_array_equal(rows["action"], _f32([[0.5 * i, -0.5 * i] for i in range(FRAMES)]))


def test_ros1_messages_in_mcap_convert_with_no_mapping(tmp_path: Path) -> None:
    src = write_ros1_mcap(tmp_path / "r1.mcap")
    doc = _convert(src, tmp_path / "out")
    rows = _rows(tmp_path / "out")
    times = _frame_times(tmp_path / "out", rows)
    assert doc["frames"] == len(times)
    got = _decoded(src)
    for k, t in enumerate(times):
        np.testing.assert_array_equal(rows["observation.state"][k], _f32(_at(got["/joint_states"], t).position))
        np.testing.assert_array_equal(rows["action"][k], _f32(_at(got["/cmd"], t).position))
    info = json.loads((tmp_path / "out/meta/info.json").read_text())
    assert info["features"]["observation.state"]["names"] == ["a", "b"]
    _upright(_video(tmp_path / "out", "cam")[0])


def test_ros2_messages_without_the_ros2_profile(tmp_path: Path) -> None:
    """CDR messages in an MCAP without the ros2 profile (rosbags refuses it): decoded by mcap_ros2's decoder, on
    their header stamps with align.clock: header."""
    src = write_cdr_without_profile(tmp_path / "cdr.mcap")
    doc = _convert(src, tmp_path / "out")
    rows = _rows(tmp_path / "out")
    times = _frame_times(tmp_path / "out", rows)
    got = _decoded(src)
    assert doc["frames"] == len(times)
    for k, t in enumerate(times):
        np.testing.assert_array_equal(rows["observation.state"][k], _f32(_at(got["/joint_states"], t).position))
    mapping = tmp_path / "m.yaml"
    mapping.write_text(json.dumps({
        "fps": 10, "task": "t", "state": {"topic": "/joint_states", "joints": ["b"]},
        "action": {"topic": "/action", "field": "data"}, "align": {"clock": "header", "max_staleness": 0.01},
    }))  # fmt: skip
    doc = _convert(src, tmp_path / "header", "--mapping", str(mapping))
    rows = _rows(tmp_path / "header")
    assert doc["frames"] == FRAMES  # the stamps put every message on the grid
    np.testing.assert_array_equal(_f32(rows["observation.state"]).reshape(-1), _f32([-i for i in range(FRAMES)]))


def test_a_missing_decoder_names_its_extra(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Without the mcap_profiles extra (mcap_protobuf not importable), a protobuf file is one line naming it."""
    src = write_foxglove(tmp_path / "fox.mcap")
    monkeypatch.setitem(sys.modules, "mcap_protobuf.decoder", None)
    run = run_inproc("convert", str(src), str(tmp_path / "out"), "--codec", "h264")
    assert run.returncode == 2 and len(run.stderr.strip().splitlines()) == 1, run.stderr
    assert "protobuf messages need the 'mcap_profiles' extra: pip install 'openral-data[mcap_profiles]'" in run.stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.skipif(not REAL.is_dir(), reason="the third-party cart-pole MCAP is not in ../shared/fixtures")
def test_a_real_foxglove_jsonschema_mcap(tmp_path: Path) -> None:
    """robotics-laboratory/cart-pole's simulation log (Foxglove's Python mcap 1.1.1, jsonschema channels, a
    `foxglove.Log` channel without messages): every state field of every frame equals json.loads of the message."""
    src = REAL / "simulation_example.mcap"
    doc = _convert(src, tmp_path / "out")
    rows = _rows(tmp_path / "out")
    states = _decoded(src)["/cartpole/state"]
    assert doc["frames"] == len(rows["frame_index"]) == len(states) == 387
    keys = ["cart_position", "cart_velocity", "cart_acceleration", "pole_angle", "pole_angular_velocity", "stamp",
            "error"]  # fmt: skip
    want = np.asarray([[msg[key] for key in keys] for _, msg in states], np.float32)
    np.testing.assert_array_equal(np.asarray(rows["observation.state"], np.float32), want)
