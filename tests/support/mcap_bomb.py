"""A crafted MCAP file with one zstd chunk of zeros: a decompression bomb (a chunk declaring 1,000 bytes whose
data expands to gigabytes) or, `honest`, one whose declared size is true. Made cheaply: one 64 MiB frame of
zeros compressed once (~2 KB) and repeated (a zstd stream may hold many frames)."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
from backports import zstd

FRAME = 64 << 20
MAGIC = b"\x89MCAP0\r\n"


def _record(op: int, body: bytes) -> bytes:
    return bytes([op]) + struct.pack("<Q", len(body)) + body


def _string(text: str) -> bytes:
    return struct.pack("<I", len(text)) + text.encode()


def write_bomb(path: Path, expands_to: int, honest: bool = False) -> Path:
    """`path`: an MCAP whose one chunk's zstd data expands to `expands_to` bytes (a multiple of 1 MiB)."""
    size = min(expands_to, FRAME)
    frame = zstd.compress(bytes(size), level=1)
    data = frame * (expands_to // size)
    declared = expands_to if honest else 1000
    chunk = struct.pack("<QQQI", 0, 1, declared, 0) + _string("zstd") + struct.pack("<Q", len(data)) + data
    path.write_bytes(
        MAGIC
        + _record(0x01, _string("ros2") + _string("bomb"))
        + _record(0x06, chunk)
        + _record(0x0F, struct.pack("<I", 0))
        + _record(0x02, struct.pack("<QQI", 0, 0, 0))  # no summary: readers scan, and so reach the chunk
        + MAGIC
    )
    return path


def write_ros1_bomb(path: Path, expands_to: int, honest: bool = False) -> Path:
    """`path`: a real ROS 1 bag (rosbags' writer, bz2 chunks) holding one message of `expands_to` zero bytes; unless
    `honest`, its chunk header then declares 1,000 bytes uncompressed (the field is a fixed-width u32)."""
    from rosbags.rosbag1 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC)
    msgtype = "std_msgs/msg/UInt8MultiArray"
    msg = store.types[msgtype](
        layout=store.types["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0), data=np.zeros(expands_to, np.uint8)
    )
    writer = Writer(path)
    writer.set_compression(Writer.CompressionFormat.BZ2)
    with writer:
        conn = writer.add_connection("/blob", msgtype, typestore=store)
        writer.write(conn, 1, store.serialize_ros1(msg, msgtype))
    if not honest:
        raw = bytearray(path.read_bytes())
        at = raw.index(b"\x09\x00\x00\x00size=") + 9  # the chunk header's size field (no other record has one)
        raw[at : at + 4] = struct.pack("<I", 1000)
        path.write_bytes(bytes(raw))
    return path
