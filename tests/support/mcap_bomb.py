"""A crafted MCAP file with one zstd chunk of zeros: a decompression bomb (a chunk declaring 1,000 bytes whose
data expands to gigabytes) or, `honest`, one whose declared size is true. Made cheaply: one 64 MiB frame of
zeros compressed once (~2 KB) and repeated (a zstd stream may hold many frames)."""

from __future__ import annotations

import struct
from pathlib import Path

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
