"""MCAP files of other profiles than ROS 2, written by the real writers: Foxglove's SDK (its protobuf well-known
schemas), the `mcap` library's Writer (JSON channels with a jsonschema) and `mcap_ros1`'s Writer (ROS 1 messages).

Each holds `FRAMES` frames at 10 Hz (log time = the message's own timestamp), a camera whose top rows are red
and bottom rows blue (so an upside-down conversion shows), and numbers that change every frame."""

from __future__ import annotations

import base64
import io
import json
from pathlib import Path

import numpy as np
import numpy.typing as npt
from PIL import Image

FRAMES = 12
T0 = 1_700_000_000_000_000_000
STEP = 100_000_000  # 10 Hz
H, W = 24, 32
BAND = 6  # rows of red at the top, of blue at the bottom


def image(i: int) -> npt.NDArray[np.uint8]:
    """Frame i's picture: red top band, blue bottom band, grey between whose level is 8 * i."""
    img = np.full((H, W, 3), 8 * i, np.uint8)
    img[:BAND] = (255, 0, 0)
    img[-BAND:] = (0, 0, 255)
    return img


def png(img: npt.NDArray[np.uint8]) -> bytes:
    buf = io.BytesIO()
    Image.fromarray(img).save(buf, format="PNG")
    return buf.getvalue()


def write_foxglove(path: Path) -> Path:
    """Foxglove's SDK, protobuf: /cam (CompressedImage, PNG), /wrist (RawImage rgb8), /tf (FrameTransform of the
    gripper), /cmd/pose (PoseInFrame: the commanded pose), /gps (LocationFix)."""
    import foxglove
    from foxglove.channels import (
        CompressedImageChannel,
        FrameTransformChannel,
        LocationFixChannel,
        PoseInFrameChannel,
        RawImageChannel,
    )
    from foxglove.messages import (
        CompressedImage,
        FrameTransform,
        LocationFix,
        Pose,
        PoseInFrame,
        Quaternion,
        RawImage,
        Timestamp,
        Vector3,
    )

    ctx = foxglove.Context()
    with foxglove.open_mcap(path, context=ctx):
        cam, wrist = CompressedImageChannel("/cam", context=ctx), RawImageChannel("/wrist", context=ctx)
        tf, cmd = FrameTransformChannel("/tf", context=ctx), PoseInFrameChannel("/cmd/pose", context=ctx)
        gps = LocationFixChannel("/gps", context=ctx)
        for i in range(FRAMES):
            ns = T0 + i * STEP
            ts = Timestamp(sec=ns // 1_000_000_000, nsec=ns % 1_000_000_000)
            img = image(i)
            cam.log(CompressedImage(timestamp=ts, frame_id="cam", data=png(img), format="png"), log_time=ns)
            raw = img[::-1].copy()  # the wrist camera sees it flipped
            wrist.log(RawImage(timestamp=ts, frame_id="wrist", width=W, height=H, encoding="rgb8", step=3 * W,
                               data=raw.tobytes()), log_time=ns)  # fmt: skip
            tf.log(FrameTransform(timestamp=ts, parent_frame_id="base", child_frame_id="gripper",
                                  translation=Vector3(x=0.1 * i, y=-0.5, z=1.0 + i),
                                  rotation=Quaternion(x=0.0, y=0.0, z=np.sin(i / 10), w=np.cos(i / 10))),
                   log_time=ns)  # fmt: skip
            pose = Pose(position=Vector3(x=i, y=2 * i, z=3.5), orientation=Quaternion(x=0.5, y=0.5, z=0.5, w=0.5))
            cmd.log(PoseInFrame(timestamp=ts, frame_id="base", pose=pose), log_time=ns)
            gps.log(LocationFix(timestamp=ts, latitude=59.3 + i * 1e-5, longitude=18.1, altitude=12.0 + i),
                    log_time=ns)  # fmt: skip
    return path


JOINTS_SCHEMA = {
    "type": "object",
    "properties": {
        "timestamp": {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}},
        "name": {"type": "array", "items": {"type": "string"}},
        "position": {"type": "array", "items": {"type": "number"}},
    },
}
IMAGE_SCHEMA = {  # Foxglove's CompressedImage in JSON: data is base64
    "title": "foxglove.CompressedImage",
    "type": "object",
    "properties": {
        "timestamp": {"type": "object", "properties": {"sec": {"type": "integer"}, "nsec": {"type": "integer"}}},
        "frame_id": {"type": "string"},
        "data": {"type": "string", "contentEncoding": "base64"},
        "format": {"type": "string"},
    },
}
COMMAND_SCHEMA = {"type": "object", "properties": {"gripper": {"type": "number"}, "velocity": {"type": "array"}}}


def joint_positions(i: int) -> list[float]:
    return [0.25 * i, -1.0 + 0.125 * i, 3.0]


def write_json(path: Path) -> Path:
    """The `mcap` library's Writer, JSON with jsonschema: /joints (name + position, keys written in another order
    than the schema's), /camera (foxglove.CompressedImage, base64 PNG), /command (gripper, velocity)."""
    from mcap.writer import Writer

    with path.open("wb") as f:
        w = Writer(f)
        w.start(profile="", library="openral-data tests")
        ids = {}
        for topic, schema in (("/joints", JOINTS_SCHEMA), ("/camera", IMAGE_SCHEMA), ("/command", COMMAND_SCHEMA)):
            sid = w.register_schema(str(schema.get("title", topic.strip("/"))), "jsonschema",
                                    json.dumps(schema).encode())  # fmt: skip
            ids[topic] = w.register_channel(topic, "json", sid)
        for i in range(FRAMES):
            ns = T0 + i * STEP
            ts = {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}
            msgs = {
                "/joints": {"position": joint_positions(i), "name": ["j1", "j2", "j3"], "timestamp": ts},
                "/camera": {"timestamp": ts, "frame_id": "c", "format": "png",
                            "data": base64.b64encode(png(image(i))).decode()},
                "/command": {"velocity": [0.5 * i, -0.5 * i], "gripper": float(i % 2)},
            }  # fmt: skip
            for topic, msg in msgs.items():
                w.add_message(ids[topic], log_time=ns, data=json.dumps(msg).encode(), publish_time=ns)
        w.finish()
    return path


def _ros1_class(msgtype: str) -> type:
    from mcap_ros1._vendor.genpy import dynamic  # type: ignore[import-untyped]
    from rosbags.typesys import Stores, get_typestore

    text, _ = get_typestore(Stores.ROS1_NOETIC).generate_msgdef(msgtype, ros_version=1)
    name = msgtype.replace("/msg/", "/")
    return dynamic.generate_dynamic(name, text)[name]  # type: ignore[no-any-return]


def write_ros1_mcap(path: Path) -> Path:
    """`mcap_ros1`'s Writer (profile ros1): /joint_states (JointState), /cam/image_raw (Image rgb8), /cmd
    (JointState: the commanded positions)."""
    from mcap_ros1.writer import Writer

    joint_state, img_t = _ros1_class("sensor_msgs/msg/JointState"), _ros1_class("sensor_msgs/msg/Image")
    with path.open("wb") as f:
        w = Writer(f)
        for i in range(FRAMES):
            ns = T0 + i * STEP
            js = joint_state(name=["a", "b"], position=[0.5 * i, -0.25 * i], velocity=[], effort=[])
            js.header.stamp.secs, js.header.stamp.nsecs = divmod(ns, 1_000_000_000)
            w.write_message("/joint_states", js, log_time=ns)
            cmd = joint_state(name=["a", "b"], position=[0.5 * i + 0.1, -0.25 * i - 0.1], velocity=[], effort=[])
            w.write_message("/cmd", cmd, log_time=ns)
            pic = img_t(height=H, width=W, encoding="rgb8", is_bigendian=0, step=3 * W, data=image(i).tobytes())
            w.write_message("/cam/image_raw", pic, log_time=ns)
        w.finish()
    return path


def write_cdr_without_profile(path: Path) -> Path:
    """The `mcap` library's Writer, no profile, ROS 2 messages (ros2msg schemas, CDR by rosbags): /joint_states
    (JointState, header stamped), /action (Float32MultiArray). rosbags refuses it (profile is not ros2)."""
    from mcap.writer import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    t = store.types
    with path.open("wb") as f:
        w = Writer(f)
        w.start(profile="", library="openral-data tests")
        ids = {}
        for topic, msgtype in (("/joint_states", "sensor_msgs/msg/JointState"),
                               ("/action", "std_msgs/msg/Float32MultiArray")):  # fmt: skip
            text, _ = store.generate_msgdef(msgtype, ros_version=2)
            ids[topic] = (w.register_channel(topic, "cdr", w.register_schema(msgtype, "ros2msg", text.encode())),
                          msgtype)  # fmt: skip
        layout = t["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0)
        for i in range(FRAMES):
            ns = T0 + i * STEP
            stamp = t["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
            header = t["std_msgs/msg/Header"](stamp=stamp, frame_id="")
            js = t["sensor_msgs/msg/JointState"](header=header, name=["a", "b"], position=np.array([i, -i], float),
                                                 velocity=np.zeros(0), effort=np.zeros(0))  # fmt: skip
            act = t["std_msgs/msg/Float32MultiArray"](layout=layout, data=np.array([0.5 * i], np.float32))
            for topic, msg in (("/joint_states", js), ("/action", act)):
                cid, msgtype = ids[topic]
                w.add_message(cid, log_time=ns, data=bytes(store.serialize_cdr(msg, msgtype)), publish_time=ns)
        w.finish()
    return path


def write_foxglove_lists(path: Path) -> Path:
    """Foxglove's SDK, protobuf: /tf (FrameTransforms of frames a and b), /poses (PosesInFrame of two poses),
    /depth (RawImage 16UC1 millimetres, 16x16)."""
    import foxglove
    from foxglove.channels import FrameTransformsChannel, PosesInFrameChannel, RawImageChannel
    from foxglove.messages import FrameTransform, FrameTransforms, Pose, PosesInFrame, Quaternion, RawImage, Vector3

    ctx = foxglove.Context()
    with foxglove.open_mcap(path, context=ctx):
        tf, poses = FrameTransformsChannel("/tf", context=ctx), PosesInFrameChannel("/poses", context=ctx)
        depth = RawImageChannel("/depth", context=ctx)
        for i in range(FRAMES):
            ns = T0 + i * STEP
            frames = [FrameTransform(child_frame_id=c, translation=Vector3(x=i, y=k, z=-i), rotation=Quaternion(w=1))
                      for k, c in enumerate("ab")]  # fmt: skip
            tf.log(FrameTransforms(transforms=frames), log_time=ns)
            pose = [Pose(position=Vector3(x=k, y=i), orientation=Quaternion(z=1.0)) for k in range(2)]
            poses.log(PosesInFrame(frame_id="w", poses=pose), log_time=ns)
            mm = (np.arange(256, dtype="<u2") * 10 + 500 + i).tobytes()
            depth.log(RawImage(width=16, height=16, encoding="16UC1", step=32, data=mm), log_time=ns)
    return path
