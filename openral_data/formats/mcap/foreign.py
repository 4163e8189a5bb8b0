"""MCAP files of any profile but ROS 2 (what Foxglove's SDKs and the `mcap` library write): protobuf, JSON (with
a jsonschema or none) and ROS 1 messages, decoded by mcap's own decoder factories (`mcap_protobuf`,
`mcap_ros1`: the `mcap_profiles` extra, imported only when a file needs them; JSON by `json.loads`; ROS 2's
CDR in a file without the ros2 profile by `mcap_ros2`'s), and read
the way `convert` reads a bag through rosbags (`ForeignMcap`: connections, messages in log-time order, decode).

A decoded message is a `Fields`: its fields by name as rosbags' messages have them (a JSON object's keys, a
protobuf message's fields, a ROS 1 message's slots), bytes as uint8 arrays (a JSON field whose schema says
``contentEncoding: base64`` decoded), nested messages as `Fields`; `numpy.asarray` of one is its numbers (every
numeric leaf in schema order, its `timestamp` left out: a pose, a vector, a transform as one vector), and
`stamp_ns` is its own time (Foxglove's `timestamp`, a ROS `header.stamp`). A ROS 1 schema `pkg/Type` is
named `pkg/msg/Type`, as rosbags names ROS 1 types. The file is walked by `chunks.check_mcap` (bounded records
and chunks) before `mcap`'s reader opens it; a JSON message is at most `MAX_JSON_BYTES`.
"""

from __future__ import annotations

import base64
import binascii
import json
import struct
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np
import numpy.typing as npt
from mcap.exceptions import McapError
from mcap.reader import McapReader, make_reader
from mcap.records import Channel, Schema
from rosbags.interfaces import Connection, ConnectionExtRosbag2, MessageDefinition, MessageDefinitionFormat

from openral_data.errors import BagError, install_hint
from openral_data.formats.mcap.chunks import MAGIC, check_mcap
from openral_data.paths import regular_file

ROS2 = "ros2"
# Foxglove's well-known image schemas, read as sensor_msgs' Image and CompressedImage are (the same fields, a
# RawImage without is_bigendian: little-endian)
FOXGLOVE_IMAGE_TYPES = ("foxglove.RawImage", "foxglove.CompressedImage")
MAX_JSON_BYTES = 64 << 20  # one JSON message (a base64 camera frame of a few MB fits many times over)
_DEPTH_LIMIT = 64  # nesting of a decoded message
# what mcap's reader and the decoders raise on a damaged file or message
READ_ERRORS = (McapError, ValueError, KeyError, IndexError, EOFError, OSError, struct.error, TypeError,
               RuntimeError, RecursionError)  # fmt: skip


def mcap_profile(path: Path) -> str | None:
    """The profile of the MCAP file `path`'s header record; None when it is no MCAP file (or too short to say)."""
    with regular_file(path).open("rb") as f:
        head = f.read(8 + 9 + 4 + 256)
    if head[:8] != MAGIC or len(head) < 21 or head[8] != 0x01:
        return None
    size = struct.unpack_from("<I", head, 17)[0]
    return head[21 : 21 + size].decode("utf-8", "replace") if 21 + size <= len(head) else None


def is_foreign_mcap(path: Path) -> bool:
    """`path` is an ``.mcap`` file whose profile is not ros2 (rosbags reads those)."""
    if not (path.suffix.lower() == ".mcap" and path.is_file()):
        return False
    profile = mcap_profile(path)
    return profile is not None and profile != ROS2


class Fields:
    """A decoded message read by field name (see the module): `_value` the decoder's object, `_names` its
    fields in order."""

    __slots__ = ("_names", "_value")

    def __init__(self, value: Any, names: list[str]) -> None:
        self._value = value
        self._names = names

    def field_names(self) -> list[str]:
        return list(self._names)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_") or name not in self._names:
            raise AttributeError(name)
        raw = self._value[name] if isinstance(self._value, dict) else getattr(self._value, name)
        return wrap(raw)

    def __repr__(self) -> str:
        return f"Fields({', '.join(self._names)})"

    def numbers(self) -> list[float]:
        """Every numeric leaf, in field order (a nested message's in place, `timestamp` left out)."""
        out: list[float] = []
        for name in self._names:
            if name != "timestamp":
                _numbers(getattr(self, name), out, 0)
        return out

    def __array__(self, dtype: Any = None, copy: bool | None = None) -> npt.NDArray[Any]:
        return np.asarray(self.numbers(), dtype=dtype if dtype is not None else np.float64)

    def stamp_ns(self) -> int | None:
        """The message's own time in ns: Foxglove's `timestamp` ({sec, nsec} or protobuf seconds, nanos), a ROS 1
        `header.stamp` (secs, nsecs); None without one."""
        if "timestamp" in self._names:
            return _time_ns(self.timestamp)
        header = getattr(self, "header", None)
        return _time_ns(header.stamp) if isinstance(header, Fields) and "stamp" in header._names else None


def _time_ns(stamp: Any) -> int | None:
    if not isinstance(stamp, Fields):
        return None
    for sec, nsec in (("sec", "nsec"), ("seconds", "nanos"), ("secs", "nsecs"), ("sec", "nanosec")):
        if sec in stamp._names and nsec in stamp._names:
            return int(getattr(stamp, sec)) * 1_000_000_000 + int(getattr(stamp, nsec))
    return None


def _numbers(value: Any, out: list[float], depth: int) -> None:
    if depth > _DEPTH_LIMIT:
        raise ValueError("a message nested too deep")
    if isinstance(value, bool | int | float | np.integer | np.floating | np.bool_):
        out.append(float(value))
    elif isinstance(value, Fields):
        out.extend(value.numbers())
    elif isinstance(value, list | tuple):
        for item in value:
            _numbers(item, out, depth + 1)
    elif isinstance(value, np.ndarray) and value.dtype.kind in "biuf":
        out.extend(float(v) for v in value.reshape(-1))


def wrap(raw: Any) -> Any:
    """A decoded value as `Fields` reads it: bytes as uint8 arrays, messages as `Fields`, sequences as lists."""
    if isinstance(raw, bytes | bytearray):
        return np.frombuffer(bytes(raw), dtype=np.uint8)
    if isinstance(raw, str | bool | int | float | type(None)):
        return raw
    if isinstance(raw, dict):
        return Fields(raw, [str(k) for k in raw])
    if isinstance(raw, list | tuple):
        return [wrap(v) for v in raw]
    descriptor = getattr(raw, "DESCRIPTOR", None)
    if descriptor is not None and hasattr(descriptor, "fields"):  # a protobuf message
        return Fields(raw, [f.name for f in descriptor.fields])
    slots = getattr(raw, "__slots__", None)
    if isinstance(slots, list | tuple) and hasattr(raw, "_full_text"):  # a ROS 1 (genpy) or mcap_ros2 message
        return Fields(raw, [str(s) for s in slots])
    if hasattr(raw, "secs") and hasattr(raw, "nsecs"):  # genpy Time / Duration
        return Fields(raw, ["secs", "nsecs"])
    try:
        return [wrap(v) for v in raw]  # a protobuf repeated field
    except TypeError:
        return raw


# -- JSON ------------------------------------------------------------------------------------------------------
def _json_decoder(schema: Any) -> Callable[[bytes], Any]:
    def decode(data: bytes) -> Any:
        if len(data) > MAX_JSON_BYTES:
            raise ValueError(f"a JSON message of {len(data)} bytes (more than {MAX_JSON_BYTES})")
        return _by_schema(json.loads(data), schema, 0)

    return decode


def _by_schema(value: Any, schema: Any, depth: int) -> Any:
    """`value` with the jsonschema's base64 strings as bytes and its objects' keys in the schema's order."""
    if depth > _DEPTH_LIMIT:
        raise ValueError("a JSON message nested too deep")
    if not isinstance(schema, dict):
        return value
    if isinstance(value, str) and schema.get("contentEncoding") == "base64":
        try:
            return base64.b64decode(value, validate=True)
        except binascii.Error as exc:
            raise ValueError(f"a base64 field does not decode: {exc}") from None
    if isinstance(value, list):
        return [_by_schema(v, schema.get("items"), depth + 1) for v in value]
    props = schema.get("properties")
    if isinstance(value, dict) and isinstance(props, dict):
        ordered = {k: _by_schema(value[k], props[k], depth + 1) for k in props if k in value}
        return {**ordered, **{k: v for k, v in value.items() if k not in ordered}}
    return value


# -- the reader ----------------------------------------------------------------------------------------------
def why(exc: BaseException) -> str:
    """An exception's first line, or its class name when it says nothing (mcap's reader cut short: EOFError())."""
    text = str(exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__


def _decoder_for(path: Path, channel: Channel, schema: Schema | None) -> Callable[[bytes], Any]:
    """mcap's own decoder for a channel: JSON by json.loads, protobuf and ROS 1 by their decoder factories."""
    encoding = channel.message_encoding
    if encoding == "json":
        return _json_decoder(json.loads(schema.data) if schema is not None and schema.data else None)
    try:
        if encoding == "protobuf":
            from mcap_protobuf.decoder import DecoderFactory
        elif encoding == "ros1":
            from mcap_ros1.decoder import DecoderFactory  # type: ignore[assignment]
        elif encoding == "cdr":  # ROS 2 messages in a file without the ros2 profile (mcap-ros2-support: core)
            from mcap_ros2.decoder import DecoderFactory  # type: ignore[assignment]
        else:
            raise BagError(f"{path}: {channel.topic}: message encoding {encoding!r} is not read (json, protobuf, "
                           "ros1, cdr)", code="bag.type")  # fmt: skip
    except ImportError:
        raise BagError(f"{path}: {channel.topic}: {encoding} messages need the 'mcap_profiles' extra: "
                       f"{install_hint('mcap_profiles')}", code="bag.type") from None  # fmt: skip
    decoder = DecoderFactory().decoder_for(encoding, schema)
    if decoder is None:
        raise BagError(f"{path}: {channel.topic}: {encoding} messages without a schema of their encoding",
                       code="bag.type")  # fmt: skip
    return decoder


def _type_name(schema: Schema | None, channel: Channel) -> str:
    """A channel's message type: its schema's name (a ROS 1 `pkg/Type` as `pkg/msg/Type`), or its encoding."""
    if schema is None or not schema.name:
        return channel.message_encoding
    name = schema.name
    if schema.encoding == "ros1msg" and name.count("/") == 1:
        pkg, typ = name.split("/")
        return f"{pkg}/msg/{typ}"
    return name


class ForeignMcap:
    """One non-ROS-2 MCAP file, read as `convert` reads rosbags' `AnyReader` (connections with message counts,
    `messages` in log-time order, `duration`), each message decoded by `decode` into `Fields`."""

    def __init__(self, path: Path) -> None:
        check_mcap(path)  # bounded records and chunks, before mcap's reader allocates what they declare
        self.path = path
        self._file: IO[bytes] = regular_file(path).open("rb")
        self._decoders: dict[str, Callable[[bytes], Any]] = {}
        try:
            self._reader: McapReader = make_reader(self._file)
            self._open()
        except READ_ERRORS as exc:
            self._file.close()
            raise BagError(f"{path}: cannot read bag: {why(exc)}", code="bag.invalid") from None
        except BagError:
            self._file.close()
            raise

    def _open(self) -> None:
        summary = self._reader.get_summary()
        counts: dict[int, int] = {}
        times: list[int] = []
        if summary is not None and summary.statistics is not None:
            counts = dict(summary.statistics.channel_message_counts)
            if summary.statistics.message_count:
                times = [summary.statistics.message_start_time, summary.statistics.message_end_time]
            channels, schemas = summary.channels, summary.schemas
        else:  # no summary: one pass over the (bounded) records
            channels, schemas = {}, {}
            for schema, channel, message in self._reader.iter_messages(log_time_order=False):
                channels[channel.id] = channel
                if schema is not None:
                    schemas[schema.id] = schema
                counts[channel.id] = counts.get(channel.id, 0) + 1
                times = [min(times[0], message.log_time), max(times[1], message.log_time)] if times else [
                    message.log_time, message.log_time]  # fmt: skip
        self.duration = times[1] - times[0] + 1 if times else 0
        self._types: dict[str, tuple[Channel, Schema | None]] = {}
        self.connections: list[Connection] = []
        for cid, channel in sorted(channels.items()):
            schema = schemas.get(channel.schema_id) if channel.schema_id else None
            msgtype = self._unique_type(_type_name(schema, channel), channel, schema)
            readable = schema is not None and schema.encoding != "protobuf"  # a .proto set is binary
            text = schema.data.decode("utf-8", "replace") if schema is not None and readable else ""
            self.connections.append(Connection(
                cid, channel.topic, msgtype, MessageDefinition(MessageDefinitionFormat.NONE, text), "",
                counts.get(cid, 0), ConnectionExtRosbag2(channel.message_encoding, []), self,
            ))  # fmt: skip

    def _unique_type(self, name: str, channel: Channel, schema: Schema | None) -> str:
        """`name`, or `name (#id)` when another schema already has that name with another encoding or data."""
        known = self._types.get(name)
        same = (
            known is not None
            and known[0].message_encoding == channel.message_encoding
            and (
                (known[1] is None and schema is None)
                or (known[1] is not None and schema is not None and known[1].data == schema.data)
            )
        )
        if known is not None and not same:
            name = f"{name} (#{schema.id if schema is not None else channel.id})"
        self._types.setdefault(name, (channel, schema))
        return name

    def messages(self, connections: list[Connection]) -> Iterator[tuple[Connection, int, bytes]]:
        """(connection, log time ns, raw bytes) of the connections' messages in log-time order."""
        by_id = {c.id: c for c in connections}
        topics = sorted({c.topic for c in connections})
        if not topics:
            return
        it = self._reader.iter_messages(topics=topics, log_time_order=True)
        while True:
            try:
                _, channel, message = next(it)
            except StopIteration:
                return
            except READ_ERRORS as exc:
                raise BagError(f"{self.path}: cannot read bag: {why(exc)}", code="bag.invalid") from None
            conn = by_id.get(channel.id)
            if conn is not None:
                yield conn, message.log_time, message.data

    def decode(self, raw: bytes, msgtype: str) -> Any:
        """One message of type `msgtype` decoded (by mcap's decoder for its channel) as `Fields`."""
        decoder = self._decoders.get(msgtype)
        if decoder is None:
            decoder = self._decoders[msgtype] = self._decoder(msgtype)
        try:
            value = wrap(decoder(raw))
        except Exception as exc:  # noqa: BLE001 - the decoders' own errors (protobuf's DecodeError, genpy's)
            raise BagError(f"{self.path}: a {msgtype} message does not decode: {why(exc)}",
                           code="bag.invalid") from None  # fmt: skip
        if not isinstance(value, Fields):
            raise BagError(f"{self.path}: a {msgtype} message is {type(value).__name__}, not a message",
                           code="bag.invalid")  # fmt: skip
        return value

    def _decoder(self, msgtype: str) -> Callable[[bytes], Any]:
        channel, schema = self._types[msgtype]
        try:
            return _decoder_for(self.path, channel, schema)
        except BagError:
            raise
        except Exception as exc:  # noqa: BLE001 - a schema the decoder factory cannot load (protobuf's, genpy's)
            raise BagError(f"{self.path}: {channel.topic}: the {channel.message_encoding} schema of {msgtype} does "
                           f"not load: {why(exc)}",
                           code="bag.invalid") from None  # fmt: skip

    def close(self) -> None:
        self._file.close()
