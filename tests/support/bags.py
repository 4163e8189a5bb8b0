"""A synthetic multi-rate robot log, written as a real ROS 1 bag, ROS 2 bags (sqlite3, mcap) and plain MCAP.

Streams (times in ms from BASE; k is the sample's index on its own topic):

* /joint_states  sensor_msgs/JointState, 100 Hz, names [extra, j2, j1, j3], position [999, 2k+0.5, k, 3k]
* /cmd           std_msgs/Float64MultiArray, 20 Hz, data [k, -k]
* /cam/image_raw sensor_msgs/Image rgb8 32x24, every 66 ms, solid colour (20k mod 256, 50, 200)
* /cam2/compressed sensor_msgs/CompressedImage png 32x24, 10 Hz, solid colour (20k mod 256, 100, 30)
* /task          std_msgs/String: "stack the blocks" at 0, "unstack" at 1000
* /diagnostics   std_msgs/String, 1 Hz: not mapped

With `depth=True` (RealSense-like depth, `DEPTH_MAPPING`), also:

* /camera/depth/image_rect_raw  sensor_msgs/Image 16UC1 64x48, every 66 ms: `depth_mm(k)` millimetres, with
  0 (no return) and 12000 (beyond depth_max) pixels
* /camera/depth32/image         sensor_msgs/Image 32FC1 64x48, 10 Hz: `depth_m(k)` metres, with NaN, +inf, -inf
* /camera/depth/camera_info, /cam/camera_info  sensor_msgs/CameraInfo, 1 Hz: `camera_info(...)` (64x48, 32x24)
* /camera/depth/compressedDepth, /camera/depth32/compressedDepth  sensor_msgs/CompressedImage: the same frames
  in image_transport's compressedDepth PNG (`compressed_depth`: 16UC1 as is, 32FC1 as quantized inverse depth)

The writers' `Flaw` (default: none) plants a mistake a real driver makes: header stamps left at zero, or
/cam/image_raw carrying depth (16UC1 millimetres or 32FC1 metres) instead of rgb8, or /cam2/compressed in
image_transport's compressed depth format.
"""

from __future__ import annotations

import dataclasses
import io
import struct
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, Literal

import numpy as np
from PIL import Image as PILImage
from rosbags.rosbag1 import Writer as Writer1
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Writer2
from rosbags.typesys import Stores, get_typestore

BASE = 1_700_000_000 * 10**9
MS = 10**6
H, W = 24, 32
TASKS = [(0, "stack the blocks"), (1000, "unstack")]

MAPPING: dict[str, Any] = {
    "fps": 10,
    "robot_type": "synthetic_arm",
    "task_topic": "/task",
    "state": {"topic": "/joint_states", "field": "position", "joints": ["j1", "j2", "j3"]},
    "action": {"topic": "/cmd", "field": "data", "names": ["vx", "vy"]},
    "cameras": {"front": "/cam/image_raw", "side": "/cam2/compressed"},
    "align": {"method": "previous", "max_staleness": 0.1},
}

TYPES = {
    "/joint_states": "sensor_msgs/msg/JointState",
    "/cmd": "std_msgs/msg/Float64MultiArray",
    "/cam/image_raw": "sensor_msgs/msg/Image",
    "/cam2/compressed": "sensor_msgs/msg/CompressedImage",
    "/task": "std_msgs/msg/String",
    "/diagnostics": "std_msgs/msg/String",
}


DEPTH_TYPES = {
    "/camera/depth/image_rect_raw": "sensor_msgs/msg/Image",
    "/camera/depth32/image": "sensor_msgs/msg/Image",
    "/camera/depth/camera_info": "sensor_msgs/msg/CameraInfo",
    "/cam/camera_info": "sensor_msgs/msg/CameraInfo",
    "/camera/depth/compressedDepth": "sensor_msgs/msg/CompressedImage",
    "/camera/depth32/compressedDepth": "sensor_msgs/msg/CompressedImage",
}
# image_transport's compressedDepth defaults for 32FC1: depth_quantization 100, depth_max 10 m
QUANT_A = 100.0 * (100.0 + 1.0)
QUANT_B = 1.0 - QUANT_A / 10.0
DH, DW = 48, 64
DEPTH_MAPPING: dict[str, Any] = {
    **MAPPING,
    "depth_cameras": {"depth": "/camera/depth/image_rect_raw", "depth32": "/camera/depth32/image"},
    "camera_info": {"depth": "/camera/depth/camera_info", "front": "/cam/camera_info"},
}


def depth_mm(k: int) -> np.ndarray[Any, np.dtype[np.uint16]]:
    """Frame k of the 16UC1 topic: a 150..9600 mm ramp moving with k; row 0 starts with 0 and 12000 mm."""
    y, x = np.mgrid[0:DH, 0:DW]
    d = (150 + 3 * x * y + 20 * k + 7 * x).astype(np.uint16)
    d[0, :4] = 0
    d[0, 4:8] = 12000
    return d


def depth_m(k: int) -> np.ndarray[Any, np.dtype[np.float32]]:
    """Frame k of the 32FC1 topic: a 0.2..7 m ramp moving with k; row 0 starts with NaN, +inf and -inf."""
    y, x = np.mgrid[0:DH, 0:DW]
    d = (0.2 + 0.002 * x * y + 0.05 * k + 0.001 * y).astype(np.float32)
    d[0, 0:2] = np.nan
    d[0, 2:4] = np.inf
    d[0, 4:6] = -np.inf
    return d


def camera_info(topic: str) -> dict[str, Any]:
    """The CameraInfo fields of `topic` (plumb_bob; distinct numbers per camera)."""
    w, h = (DW, DH) if topic == "/camera/depth/camera_info" else (W, H)
    f = 0.9 * w
    return {
        "frame_id": "camera_depth_optical_frame" if w == DW else "camera_color_optical_frame",
        "width": w,
        "height": h,
        "distortion_model": "plumb_bob",
        "d": [0.1, -0.25, 0.001, 0.002, 0.05],
        "k": [f, 0.0, w / 2 - 0.5, 0.0, f + 1.5, h / 2 - 0.5, 0.0, 0.0, 1.0],
        "r": [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
        "p": [f, 0.0, w / 2 - 0.5, 0.0, 0.0, f + 1.5, h / 2 - 0.5, 0.0, 0.0, 0.0, 1.0, 0.0],
    }


def compressed_depth(d: np.ndarray[Any, Any]) -> tuple[bytes, np.ndarray[Any, Any]]:
    """image_transport's compressedDepth PNG of a 16UC1 / 32FC1 frame (ConfigHeader + 16-bit PNG), and the depth
    it decodes to (32FC1: inverse depth quantized to uint16, 0 for invalid -> NaN)."""
    if d.dtype == np.uint16:
        png, decoded = d, d
    else:
        ok = np.isfinite(d) & (d > 0) & (d < 10.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = np.where(ok, QUANT_A / d + QUANT_B, 0.0)
        png = np.rint(inv).astype(np.uint16)
        with np.errstate(divide="ignore"):
            decoded = (np.float32(QUANT_A) / (png.astype(np.float32) - np.float32(QUANT_B))).astype(np.float32)
        decoded[png == 0] = np.nan
    buf = io.BytesIO()
    PILImage.fromarray(png).save(buf, format="PNG")
    header = struct.pack("<iff", 0 if d.dtype == np.uint16 else 1, QUANT_A, QUANT_B)
    return header + buf.getvalue(), decoded


# trailing-bytes (ROS 1): 4 bytes after every Image's `data`, as Intel's RealSense ROS 1 recorder writes them
Flaw = Literal["none", "zero-stamps", "16UC1", "32FC1", "compressedDepth", "trailing-bytes"]


def colour(topic: str, k: int) -> tuple[int, int, int]:
    return (20 * k % 256, 50, 200) if topic == "/cam/image_raw" else (20 * k % 256, 100, 30)


def expected(t_ms: int) -> dict[str, Any]:
    """What frame at t_ms (grid time since BASE) must hold under `previous` alignment."""
    k_js, k_cmd, k_cam, k_cam2 = t_ms // 10, t_ms // 50, t_ms // 66, t_ms // 100
    return {
        "state": [k_js, 2 * k_js + 0.5, 3 * k_js],
        "action": [k_cmd, -k_cmd],
        "front": colour("/cam/image_raw", k_cam),
        "side": colour("/cam2/compressed", k_cam2),
        "task": [text for t, text in TASKS if t <= t_ms][-1],
        "depth": depth_mm(k_cam),  # with depth=True: the 16UC1 and 32FC1 frames
        "depth32": depth_m(k_cam2),
    }


def samples(
    duration_ms: int = 2000, offset_ms: int = 0, depth: bool = False
) -> Iterator[tuple[str, int, dict[str, Any]]]:
    """(topic, time ns, plain field values) in time order."""
    out: list[tuple[int, int, str, dict[str, Any]]] = []
    order = {t: i for i, t in enumerate(TYPES | DEPTH_TYPES)}

    def add(topic: str, t_ms: int, fields: dict[str, Any]) -> None:
        out.append((t_ms, order[topic], topic, fields))

    for k, t in enumerate(range(0, duration_ms, 10)):
        pos = np.array([999.0, 2 * k + 0.5, k, 3 * k], dtype=np.float64)
        add("/joint_states", t, {"name": ["extra", "j2", "j1", "j3"], "position": pos})
    for k, t in enumerate(range(0, duration_ms, 50)):
        add("/cmd", t, {"data": np.array([k, -k], dtype=np.float64)})
    for k, t in enumerate(range(0, duration_ms, 66)):
        img = np.empty((H, W, 3), np.uint8)
        img[:] = colour("/cam/image_raw", k)
        add("/cam/image_raw", t, {"rgb": img})
    for k, t in enumerate(range(0, duration_ms, 100)):
        img = np.empty((H, W, 3), np.uint8)
        img[:] = colour("/cam2/compressed", k)
        buf = io.BytesIO()
        PILImage.fromarray(img).save(buf, format="PNG")
        add("/cam2/compressed", t, {"png": np.frombuffer(buf.getvalue(), np.uint8)})
    for t, text in TASKS:
        if t < duration_ms:
            add("/task", t, {"data": text})
    for t in range(0, duration_ms, 1000):
        add("/diagnostics", t, {"data": "ok"})
    if depth:
        for k, t in enumerate(range(0, duration_ms, 66)):
            add("/camera/depth/image_rect_raw", t, {"depth": depth_mm(k)})
            add("/camera/depth/compressedDepth", t, {"depth": depth_mm(k)})
        for k, t in enumerate(range(0, duration_ms, 100)):
            add("/camera/depth32/image", t, {"depth": depth_m(k)})
            add("/camera/depth32/compressedDepth", t, {"depth": depth_m(k)})
        for t in range(0, duration_ms, 1000):
            add("/camera/depth/camera_info", t, camera_info("/camera/depth/camera_info"))
            add("/cam/camera_info", t, camera_info("/cam/camera_info"))
    for t_ms, _, topic, fields in sorted(out, key=lambda x: (x[0], x[1])):
        yield topic, BASE + (offset_ms + t_ms) * MS, fields


def build(store: Any, topic: str, ns: int, f: dict[str, Any], ros1: bool, flaw: Flaw = "none") -> Any:
    """A rosbags message object of the topic's type from the plain field values."""
    t = store.types
    stamped = 0 if flaw == "zero-stamps" else ns
    stamp = t["builtin_interfaces/msg/Time"](sec=stamped // 10**9, nanosec=stamped % 10**9)
    header = (
        t["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id="")
        if ros1
        else t["std_msgs/msg/Header"](stamp=stamp, frame_id="")
    )
    msgtype = (TYPES | DEPTH_TYPES)[topic]
    if msgtype == "sensor_msgs/msg/CameraInfo":
        roi = t["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)
        info = {k if not ros1 else k.upper(): np.array(f[k], np.float64) for k in ("d", "k", "r", "p")}
        hdr = dataclasses.replace(header, frame_id=f["frame_id"])
        return t[msgtype](
            header=hdr, height=f["height"], width=f["width"], distortion_model=f["distortion_model"],
            binning_x=0, binning_y=0, roi=roi, **info,
        )  # fmt: skip
    if topic.endswith("/compressedDepth"):
        encoding = "16UC1" if f["depth"].dtype == np.uint16 else "32FC1"
        payload = np.frombuffer(compressed_depth(f["depth"])[0], np.uint8)
        return t[msgtype](header=header, format=f"{encoding}; compressedDepth png", data=payload)
    if topic in DEPTH_TYPES:
        d = f["depth"]
        encoding = "16UC1" if d.dtype == np.uint16 else "32FC1"
        data = np.frombuffer(d.tobytes(), np.uint8)
        return t[msgtype](
            header=header, height=DH, width=DW, encoding=encoding, is_bigendian=0, step=DW * d.itemsize, data=data
        )
    if topic == "/joint_states":
        empty = np.zeros(0, np.float64)
        return t[msgtype](header=header, name=f["name"], position=f["position"], velocity=empty, effort=empty)
    if topic == "/cmd":
        layout = t["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0)
        return t[msgtype](layout=layout, data=f["data"])
    if topic == "/cam/image_raw" and flaw in ("16UC1", "32FC1"):
        depth = np.full((H, W), 1500, np.uint16) if flaw == "16UC1" else np.full((H, W), 1.5, np.float32)
        data = np.frombuffer(depth.tobytes(), np.uint8)
        return t[msgtype](
            header=header, height=H, width=W, encoding=flaw, is_bigendian=0, step=W * depth.itemsize, data=data
        )
    if topic == "/cam/image_raw":
        return t[msgtype](
            header=header, height=H, width=W, encoding="rgb8", is_bigendian=0, step=3 * W, data=f["rgb"].reshape(-1)
        )
    if topic == "/cam2/compressed" and flaw == "compressedDepth":  # image_transport's compressed depth (PNG)
        return t[msgtype](header=header, format="16UC1; compressedDepth png", data=f["png"])
    if topic == "/cam2/compressed":
        return t[msgtype](header=header, format="png", data=f["png"])
    return t[msgtype](data=f["data"])


def _types(depth: bool) -> dict[str, str]:
    return TYPES | DEPTH_TYPES if depth else TYPES


def write_ros1(path: Path, flaw: Flaw = "none", depth: bool = False, **kw: int) -> Path:
    store = get_typestore(Stores.ROS1_NOETIC)
    types = _types(depth)
    with Writer1(path) as writer:
        conns = {topic: writer.add_connection(topic, msgtype, typestore=store) for topic, msgtype in types.items()}
        for topic, ns, f in samples(depth=depth, **kw):
            raw = bytes(store.serialize_ros1(build(store, topic, ns, f, True, flaw), types[topic]))
            if flaw == "trailing-bytes" and types[topic] == "sensor_msgs/msg/Image":
                raw += b"\x00\x00\x80\x3f"
            writer.write(conns[topic], ns, raw)
    return path


def write_ros2(path: Path, storage: str, flaw: Flaw = "none", depth: bool = False, **kw: int) -> Path:
    store = get_typestore(Stores.ROS2_HUMBLE)
    plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
    types = _types(depth)
    with Writer2(path, version=8, storage_plugin=plugin) as writer:
        conns = {topic: writer.add_connection(topic, msgtype, typestore=store) for topic, msgtype in types.items()}
        for topic, ns, f in samples(depth=depth, **kw):
            writer.write(conns[topic], ns, store.serialize_cdr(build(store, topic, ns, f, False, flaw), types[topic]))
    return path


def write_plain_mcap(path: Path, flaw: Flaw = "none", depth: bool = False, **kw: int) -> Path:
    """A plain .mcap with ros2msg schemas, written by the `mcap` package's ROS 2 writer (dict messages)."""
    from mcap_ros2.writer import Writer as McapRos2Writer

    store = get_typestore(Stores.ROS2_HUMBLE)
    with path.open("wb") as fh:
        writer = McapRos2Writer(fh)
        schemas = {
            topic: writer.register_msgdef(msgtype, store.generate_msgdef(msgtype, ros_version=2)[0])
            for topic, msgtype in _types(depth).items()
        }
        for topic, ns, f in samples(depth=depth, **kw):
            msg = _as_dict(build(store, topic, ns, f, False, flaw))
            writer.write_message(topic, schemas[topic], msg, log_time=ns, publish_time=ns)
        writer.finish()
    return path


def _as_dict(msg: Any) -> Any:
    if hasattr(msg, "__dataclass_fields__"):
        return {k: _as_dict(getattr(msg, k)) for k in msg.__dataclass_fields__ if k != "__msgtype__"}
    if isinstance(msg, list):
        return [_as_dict(x) for x in msg]
    if isinstance(msg, np.ndarray):
        return msg.tobytes() if msg.dtype == np.uint8 else msg.tolist()
    return msg


WRITERS: dict[str, Callable[[Path], Path]] = {
    "ros1": lambda d: write_ros1(d / "log.bag"),
    "ros2-sqlite3": lambda d: write_ros2(d / "log_sqlite", "sqlite3"),
    "ros2-mcap": lambda d: write_ros2(d / "log_mcap", "mcap"),
    "plain-mcap": lambda d: write_plain_mcap(d / "log.mcap"),
}
