"""MCAP files checked for bounded reading before any MCAP reader (rosbags for `convert`, rerun for `view`) opens
them: a bag is untrusted, and those readers allocate what a record declares and decompress a chunk without
bounding its output (a 200 KB zstd chunk can expand to gigabytes: a `MemoryError`, or a viewer that spins).

`check_mcap` walks the file's top-level records (no index trusted): every record is at most `MAX_RECORD_BYTES`
long (a message outside a chunk included), and every chunk is bounded by `chunk_bounds.check_chunk` (it
declares at most `MAX_RECORD_BYTES` uncompressed, and its data expands to no more than it declares). Anything
else is refused in one line before the real reader starts. `check_bag` checks any bag `convert` reads (ROS 1
ones with `formats/rosbag1`).
"""

from __future__ import annotations

import os
import struct
from pathlib import Path

from openral_data.formats.chunk_bounds import MAX_RECORD_BYTES, check_chunk, refused
from openral_data.formats.rosbag1 import check_ros1
from openral_data.paths import regular_file

MAGIC = b"\x89MCAP0\r\n"
_CHUNK, _FOOTER = 0x06, 0x02


def check_bag(bag: Path) -> None:
    """Check every ``.mcap`` of `bag` (an ``.mcap`` file, or a rosbag2 folder holding some) with `check_mcap`,
    a ROS 1 ``.bag`` with `rosbag1.check_ros1`; sqlite bags are left to their reader."""
    if bag.is_dir():
        for path in sorted(bag.glob("*.mcap")):
            check_mcap(path)
    elif bag.suffix.lower() == ".mcap":
        check_mcap(bag)
    elif bag.suffix == ".bag":
        check_ros1(bag)


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
