"""A compressed chunk of an untrusted bag (MCAP, ROS 1), decompressed no further than it declares.

Bag readers (rosbags, rerun) decompress a chunk whole and allocate what it declares, so a 200 KB chunk can
expand to gigabytes. `check_chunk` counts what a chunk's data expands to in pieces (thrown away), one byte past
its declared size at most, and refuses in one line (`bag.invalid`) a chunk that declares more than
`MAX_RECORD_BYTES` or expands past what it declares. The walkers of each format (`formats/mcap/chunks`,
`formats/rosbag1`) find the chunks.
"""

from __future__ import annotations

import bz2
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

import lz4.frame  # type: ignore[import-untyped]
from backports import zstd

from openral_data.errors import BagError

MAX_RECORD_BYTES = 1 << 30  # one chunk or message; rosbags' writer chunks ~1 MB, a camera frame is a few MB
_PIECE = 1 << 20  # decompressed at a time (and dropped)


class _Decompressor(Protocol):
    @property
    def eof(self) -> bool: ...
    @property
    def needs_input(self) -> bool: ...
    @property
    def unused_data(self) -> bytes: ...

    def decompress(self, data: bytes, max_length: int = -1) -> bytes: ...


_DECOMPRESSORS: dict[str, Callable[[], _Decompressor]] = {
    "zstd": zstd.ZstdDecompressor,
    "lz4": lz4.frame.LZ4FrameDecompressor,
    "bz2": bz2.BZ2Decompressor,  # ROS 1 bags
}


def check_chunk(path: Path, compression: str, declared: int, data: bytes) -> None:
    """Refuse a chunk of `path` (MCAP or ROS 1) declaring more than `MAX_RECORD_BYTES` uncompressed, or whose
    `compression` (zstd, lz4, bz2) `data` expands past its `declared` size (counted in pieces, never held)."""
    if declared > MAX_RECORD_BYTES:
        raise refused(path, f"a chunk declaring {declared} bytes uncompressed (more than {MAX_RECORD_BYTES})")
    make = _DECOMPRESSORS.get(compression)
    if make is None:
        return  # uncompressed (its size is the record's) or unknown: the reader says so
    try:
        size = expanded_size(make, data, declared + 1)
    except (zstd.ZstdError, RuntimeError, ValueError, OSError, EOFError) as exc:  # lz4: RuntimeError, bz2: OSError
        raise refused(path, f"a {compression} chunk that does not decompress: {exc}") from None
    if size > declared:
        raise refused(path, f"a {compression} chunk expanding past its declared {declared} bytes")


def expanded_size(make: Callable[[], Any], data: bytes, limit: int) -> int:
    """How many bytes `data` (one or more frames) decompresses to, counted up to `limit` and no further."""
    total = 0
    while data and total < limit:
        d = make()
        total += len(d.decompress(data, min(_PIECE, limit - total)))
        while not d.eof and not d.needs_input and total < limit:
            total += len(d.decompress(b"", min(_PIECE, limit - total)))
        if not d.eof:
            break
        data = d.unused_data
    return total


def refused(path: Path, what: str) -> BagError:
    """The one-line refusal of a bag whose records or chunks are not bounded."""
    return BagError(f"{path}: chunk: {what}; refusing to read it", code="bag.invalid")
