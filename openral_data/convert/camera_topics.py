"""Depth image and CameraInfo topics of a bag: what `depth_cameras` and `camera_info` in a mapping read.

A depth camera's topic carries `sensor_msgs/Image` in ``16UC1`` (millimetres, RealSense and most drivers) or
``32FC1`` (metres), or image_transport's ``compressedDepth`` PNG (a CompressedImage of format
``"16UC1; compressedDepth png"``: a 12-byte header, then a 16-bit PNG of the millimetres; ``"32FC1; ..."``: the
PNG holds inverse depth, ``depth = a / (v - b)`` with the header's (a, b), ``v = 0`` invalid -> NaN). Its frames
go to the writer as (H, W) uint16 mm / float32 m. Other CompressedImage depth formats (``rvl``) are one line.
A `CameraInfo` topic gives the camera's intrinsics, from its first message (of the first bag).
"""

from __future__ import annotations

import io
import struct
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from PIL import Image as PILImage
from rosbags.interfaces import Connection

from openral_data.convert.sources import BagReader, deserialize, read_messages
from openral_data.errors import BagError
from openral_data.formats.lerobot_v3.depth import DepthUnit

DEPTH_UNITS: dict[str, DepthUnit] = {"16uc1": "mm", "32fc1": "m"}
_DTYPES: dict[str, np.dtype[Any]] = {"mm": np.dtype("<u2"), "m": np.dtype("<f4")}
IMAGE = "sensor_msgs/msg/Image"
COMPRESSED = "sensor_msgs/msg/CompressedImage"
RAW_TYPES = (IMAGE, "foxglove.RawImage")  # Foxglove's RawImage: the same fields, little-endian
COMPRESSED_TYPES = (COMPRESSED, "foxglove.CompressedImage")
_HEADER = struct.Struct("<iff")  # image_transport's compressedDepth ConfigHeader: format, depthQuantA, depthQuantB
CAMERA_INFO = "sensor_msgs/msg/CameraInfo"


def _first(reader: BagReader, bag: Path, conn: Connection, where: str) -> Any:
    for c, _, raw in read_messages(reader, bag, [conn]):
        return deserialize(reader, bag, raw, c.msgtype)
    raise BagError(f"{where}: the topic has no messages", code="bag.empty")


def check_depth_camera(reader: BagReader, bag: Path, name: str, conn: Connection) -> DepthUnit:
    """Before anything is written: the depth camera's topic carries 16UC1 or 32FC1 images; their unit."""
    where = f"{bag}: mapping: depth_cameras.{name} ({conn.topic})"
    if conn.msgtype in COMPRESSED_TYPES:
        return _compressed_unit(str(_first(reader, bag, conn, where).format), where)
    if conn.msgtype not in RAW_TYPES:
        raise BagError(f"{where}: the topic carries {conn.msgtype}, not {' or '.join(RAW_TYPES + COMPRESSED_TYPES)}",
                       code="bag.type")  # fmt: skip
    encoding = str(_first(reader, bag, conn, where).encoding)
    unit = DEPTH_UNITS.get(encoding.lower())
    if unit is None:
        raise BagError(
            f"{where}: encoding {encoding!r} is not a depth encoding (a depth camera needs 16UC1 or 32FC1)",
            code="bag.type",
        )
    return unit


def _compressed_unit(fmt: str, where: str) -> DepthUnit:
    """The unit of a compressedDepth PNG format string; anything else is one line."""
    parts = [p.strip().lower() for p in fmt.split(";")]
    unit = DEPTH_UNITS.get(parts[0])
    if unit is None or len(parts) < 2 or parts[1] not in ("compresseddepth", "compresseddepth png"):
        raise BagError(
            f"{where}: CompressedImage format {fmt!r} is not supported for depth (a depth camera needs a "
            "16UC1/32FC1 Image, or compressedDepth png)",
            code="bag.type",
        )
    return unit


def _decode_compressed(msg: Any, unit: DepthUnit, where: str) -> npt.NDArray[Any]:
    if _compressed_unit(str(msg.format), where) != unit:
        raise BagError(f"{where}: format changed to {str(msg.format)!r} mid-stream", code="bag.field")
    raw = bytes(msg.data)
    try:
        _, quant_a, quant_b = _HEADER.unpack_from(raw)
        with PILImage.open(io.BytesIO(raw[_HEADER.size :])) as im:
            v = np.asarray(im)
    except (struct.error, OSError, ValueError) as exc:
        raise BagError(f"{where}: compressedDepth message does not decode: {exc}", code="bag.invalid") from None
    if v.ndim != 2:
        raise BagError(f"{where}: compressedDepth PNG is not single-channel", code="bag.invalid")
    if unit == "mm":
        return np.asarray(v, dtype=np.uint16)
    inv = v.astype(np.float32)
    with np.errstate(divide="ignore"):
        depth = np.float32(quant_a) / (inv - np.float32(quant_b))
    depth[v == 0] = np.nan
    return np.asarray(depth, dtype=np.float32)


def decode_depth(msg: Any, msgtype: str, unit: DepthUnit, where: str) -> npt.NDArray[Any]:
    """(H, W) uint16 millimetres or float32 metres (native byte order) from a 16UC1 / 32FC1 Image or a
    compressedDepth CompressedImage."""
    if msgtype in COMPRESSED_TYPES:
        return _decode_compressed(msg, unit, where)
    encoding = str(msg.encoding)
    if DEPTH_UNITS.get(encoding.lower()) != unit:
        raise BagError(f"{where}: encoding changed to {encoding!r} mid-stream", code="bag.field")
    dtype = _DTYPES[unit].newbyteorder(">" if getattr(msg, "is_bigendian", 0) else "<")
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    raw = np.asarray(msg.data, dtype=np.uint8)
    if step < w * dtype.itemsize or raw.size < h * step:
        raise BagError(f"{where}: {w}x{h} {encoding} image with step {step} has {raw.size} bytes", code="bag.field")
    rows = raw[: h * step].reshape(h, step)[:, : w * dtype.itemsize]
    out: npt.NDArray[Any] = np.ascontiguousarray(rows).view(dtype).reshape(h, w)
    return out.astype(_DTYPES[unit].newbyteorder("="))


def read_camera_info(reader: BagReader, bag: Path, name: str, conn: Connection) -> dict[str, Any]:
    """The intrinsics of the topic's first CameraInfo message, as the feature's `info.camera_info` keeps them
    (ROS field names in ROS 2 spelling: k, d, r, p)."""
    where = f"{bag}: mapping: camera_info.{name} ({conn.topic})"
    if conn.msgtype != CAMERA_INFO:
        raise BagError(f"{where}: the topic carries {conn.msgtype}, not {CAMERA_INFO}", code="bag.type")
    msg = _first(reader, bag, conn, where)

    def floats(field: str) -> list[float]:
        value = getattr(msg, field, None)
        value = getattr(msg, field.upper()) if value is None else value  # ROS 1 spells them D, K, R, P
        return [float(v) for v in value]

    return {
        "frame_id": str(msg.header.frame_id),
        "width": int(msg.width),
        "height": int(msg.height),
        "distortion_model": str(msg.distortion_model),
        "k": floats("k"),
        "d": floats("d"),
        "r": floats("r"),
        "p": floats("p"),
    }


def check_info_size(info: dict[str, Any], height: int, width: int, where: str) -> None:
    """A CameraInfo that names another image size than the camera's images: one line."""
    if (info["width"], info["height"]) != (width, height):
        raise BagError(
            f"{where}: CameraInfo is {info['width']}x{info['height']} but the camera's images are {width}x{height}",
            code="bag.field",
        )
