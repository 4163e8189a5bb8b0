"""MCAP files checked for bounded reading before any MCAP reader (rosbags for `convert`, rerun for `view`) opens
them: a bag is untrusted, and those readers allocate what a record declares and decompress a chunk without
bounding its output (a 200 KB zstd chunk can expand to gigabytes: a `MemoryError`, or a viewer that spins).

`check_bag` walks the file's top-level records (no index trusted): every record is at most `MAX_RECORD_BYTES`
long (a message outside a chunk included), every chunk declares at most `MAX_RECORD_BYTES` uncompressed, and its
data, decompressed in pieces and thrown away, expands to exactly the declared size; decompression stops one
byte past it. Anything else is refused in one line before the real reader starts.
"""

from __future__ import annotations

import bz2
import os
import struct
from collections.abc import Callable
from pathlib import Path
from typing import Protocol

import lz4.frame  # type: ignore[import-untyped]
from backports import zstd

from openral_data.errors import BagError
from openral_data.paths import regular_file

MAX_RECORD_BYTES = 1 << 30  # one chunk or message; rosbags' writer chunks ~1 MB, a camera frame is a few MB
MAGIC = b"\x89MCAP0\r\n"
_CHUNK, _FOOTER = 0x06, 0x02
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
    "bz2": bz2.BZ2Decompressor,  # ROS 1 bags (`formats/rosbag1`)
}


def check_bag(bag: Path) -> None:
    """Check every ``.mcap`` of `bag` (an ``.mcap`` file, or a rosbag2 folder holding some) with `check_mcap`;
    other bags (ROS 1 ``.bag``, sqlite) are left to their reader."""
    if bag.is_dir():
        for path in sorted(bag.glob("*.mcap")):
            check_mcap(path)
    elif bag.suffix.lower() == ".mcap":
        check_mcap(bag)


def check_mcap(path: Path) -> None:
    """Refuse, in one line, an MCAP file a reader could not read within bounded memory and time (see above)."""
    with regular_file(path).open("rb") as f:
        if f.read(8) != MAGIC:
            return  # not an MCAP file: its reader says so
        end = os.fstat(f.fileno()).st_size
        while header := f.read(9):
            if len(header) < 9:
                return  # truncated: the reader says so
            op, length = header[0], struct.unpack("<Q", header[1:])[0]
            if length > MAX_RECORD_BYTES:
                raise refused(path, f"a record of {length} bytes (more than {MAX_RECORD_BYTES})")
            if op == _FOOTER or f.tell() + length > end:
                return  # the end, or a truncated record: the reader says so
            if op != _CHUNK:
                f.seek(length, 1)
                continue
            _check_chunk(path, f.read(length))


def _check_chunk(path: Path, body: bytes) -> None:
    if len(body) < 32:
        return  # truncated: the reader says so
    declared = struct.unpack_from("<Q", body, 16)[0]
    name_len = struct.unpack_from("<I", body, 28)[0]
    compression = body[32 : 32 + name_len].decode("utf-8", "replace")
    data = body[32 + name_len + 8 :]
    check_chunk(path, compression, declared, data)


def check_chunk(path: Path, compression: str, declared: int, data: bytes) -> None:
    """Refuse a chunk of `path` (MCAP or ROS 1) declaring more than `MAX_RECORD_BYTES` uncompressed, or whose
    `compression` (zstd, lz4, bz2) `data` expands past its `declared` size (counted in pieces, never held)."""
    if declared > MAX_RECORD_BYTES:
        raise refused(path, f"a chunk declaring {declared} bytes uncompressed (more than {MAX_RECORD_BYTES})")
    make = _DECOMPRESSORS.get(compression)
    if make is None:
        return  # uncompressed (its size is the record's) or unknown: the reader says so
    try:
        size = _expanded_size(make, data, declared + 1)
    except (zstd.ZstdError, RuntimeError, ValueError, OSError, EOFError) as exc:  # lz4: RuntimeError, bz2: OSError
        raise refused(path, f"a {compression} chunk that does not decompress: {exc}") from None
    if size > declared:
        raise refused(path, f"a {compression} chunk expanding past its declared {declared} bytes")


def _expanded_size(make: Callable[[], _Decompressor], data: bytes, limit: int) -> int:
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
