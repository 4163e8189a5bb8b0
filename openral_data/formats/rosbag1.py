"""ROS 1 ``.bag`` files checked for bounded reading before rosbags opens them (`convert`), and their messages
decoded as ROS 1's own reader decodes them (`deserialize_ros1`). rosbags allocates the
lengths a record declares and decompresses a bz2 or lz4 chunk whole, so a small crafted chunk could expand to
gigabytes. `check_ros1` walks the file's records (no index trusted): every record header and data part is at most
`chunk_bounds.MAX_RECORD_BYTES`, and each chunk's data expands to no more than the ``size`` its header declares
(`chunk_bounds.check_chunk`, the same bound as for MCAP chunks). Anything else is refused in one line.

Record layout (ROS bag format 2.0): ``<header_len u32><header><data_len u32><data>``, the header a run of
``<field_len u32>name=value`` fields; a chunk has ``op=0x05``, ``compression`` and ``size`` (u32).
"""

from __future__ import annotations

import os
import struct
from pathlib import Path
from typing import Any, BinaryIO

from rosbags.serde import SerdeError
from rosbags.typesys.store import Typestore

from openral_data.formats.chunk_bounds import MAX_RECORD_BYTES, check_chunk, refused
from openral_data.paths import regular_file

MAGIC = b"#ROSBAG V2.0\n"
_CHUNK = b"\x05"


def check_ros1(path: Path) -> None:
    """Refuse, in one line, a ROS 1 bag a reader could not read within bounded memory and time (see above)."""
    with regular_file(path).open("rb") as f:
        if f.read(len(MAGIC)) != MAGIC:
            return  # not a ROS 1 bag 2.0: its reader says so
        end = os.fstat(f.fileno()).st_size
        while (header := _part(path, f, end, "header")) is not None:
            data_len = _length(path, f, end, "data")
            if data_len is None:
                return
            fields = _fields(header)
            if fields.get("op") != _CHUNK:
                f.seek(data_len, 1)
                continue
            size = fields.get("size", b"")
            if len(size) != 4:
                return  # damaged: the reader says so
            compression = fields.get("compression", b"none").decode("utf-8", "replace")
            check_chunk(path, compression, struct.unpack("<I", size)[0], f.read(data_len))


def _length(path: Path, f: BinaryIO, end: int, what: str) -> int | None:
    """The next u32 length, refused over the bound; None at the end or where the file is cut short."""
    raw = f.read(4)
    if len(raw) < 4:
        return None
    length: int = struct.unpack("<I", raw)[0]
    if length > MAX_RECORD_BYTES:
        raise refused(path, f"a record {what} of {length} bytes (more than {MAX_RECORD_BYTES})")
    return None if f.tell() + length > end else length


def _part(path: Path, f: BinaryIO, end: int, what: str) -> bytes | None:
    length = _length(path, f, end, what)
    return None if length is None else f.read(length)


def _fields(header: bytes) -> dict[str, bytes]:
    """A record header's ``name=value`` fields (a damaged one ends the walk of its fields)."""
    fields: dict[str, bytes] = {}
    at = 0
    while at + 4 <= len(header):
        (n,) = struct.unpack_from("<I", header, at)
        field = header[at + 4 : at + 4 + n]
        name, sep, value = field.partition(b"=")
        if not sep or len(field) < n:
            break
        fields[name.decode("utf-8", "replace")] = value
        at += 4 + n
    return fields


def deserialize_ros1(typestore: Typestore, raw: bytes | memoryview, typename: str) -> tuple[Any, int]:
    """A ROS 1 message decoded, and the number of bytes after its last field. ROS 1's own reader (genpy's
    `deserialize`) reads the fields and ignores what follows them; rosbags refuses it ("message size mismatch").
    Real recorders write such bytes: Intel's RealSense ROS 1 recorder puts 4 after every sensor_msgs/Image's
    `data`. Bytes missing before the last field are still an error (SerdeError)."""
    msgdef = typestore.get_msgdef(typename)
    try:
        message, pos = msgdef.deserialize_ros1(raw, 0, msgdef.cls, typestore)
    except (struct.error, UnicodeDecodeError, ValueError, IndexError) as exc:
        raise SerdeError(f"Could not deserialize {typename!r}: {exc}") from exc
    if pos > len(raw):
        raise SerdeError(f"ROS1 message of {typename!r} cut short ({len(raw)} bytes, its fields need {pos})")
    return message, len(raw) - pos
