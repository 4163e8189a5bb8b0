"""The mapped messages of a bag in the order of the clock the mapping aligns on (`timed_messages`), each
deserialised only when used (`Message`), and the values read from the reward, success and episode-marker topics."""

from __future__ import annotations

import heapq
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from rosbags.highlevel import AnyReader
from rosbags.interfaces import Connection

from openral_data.convert.camera_topics import decode_depth
from openral_data.convert.sources import check_image, deserialize, field_value, read_messages
from openral_data.convert.summary import ConvertSummary
from openral_data.errors import BagError
from openral_data.formats.jsonfile import parse_json
from openral_data.formats.lerobot_v3.depth import DepthUnit
from openral_data.formats.mcap.messages import decode_image
from openral_data.schemas.mapping import Mapping


class Message:
    """A bag message, deserialised on first use (most multi-rate camera samples never are)."""

    __slots__ = ("_msg", "bag", "msgtype", "raw", "reader", "topic")

    def __init__(self, reader: AnyReader, bag: Path, raw: bytes, conn: Connection) -> None:
        self.reader, self.bag, self.raw, self.msgtype, self.topic = reader, bag, raw, conn.msgtype, conn.topic
        self._msg: Any = None

    def get(self) -> Any:
        if self._msg is None:
            self._msg = deserialize(self.reader, self.bag, self.raw, self.msgtype)
        return self._msg

    def decode(self) -> npt.NDArray[np.uint8]:
        msg = self.get()
        check_image(msg, self.msgtype, f"{self.bag}: {self.topic}")  # the first message was checked, not every one
        return decode_image(msg, self.msgtype)

    def decode_depth(self, unit: DepthUnit) -> npt.NDArray[Any]:
        return decode_depth(self.get(), self.msgtype, unit, f"{self.bag}: {self.topic}")


def timed_messages(
    reader: AnyReader, bag: Path, conns: list[Connection], mapping: Mapping, summary: ConvertSummary
) -> Iterator[tuple[Connection, int, Message]]:
    """The mapped messages in the order of the clock the mapping aligns on.

    `log`: bag receive time, as stored. `header`: `header.stamp` for messages that have a header (log time for
    the others). Stamps can lag the log order (a camera stamps at exposure, the message is logged later), so
    messages are held in a heap for `align.reorder` seconds of log time; a message whose stamp is older than one
    already released is late: it is counted in the summary and not used (never reordered into decided frames).
    """
    if mapping.align.clock == "log":
        for conn, ns, raw in read_messages(reader, bag, conns):
            yield conn, ns, Message(reader, bag, raw, conn)
        return
    window = round(mapping.align.reorder * 1e9)
    heap: list[tuple[int, int, Connection, Message]] = []
    released: int | None = None
    seq = 0
    for conn, ns, raw in read_messages(reader, bag, conns):
        msg = Message(reader, bag, raw, conn)
        stamp = _header_stamp(msg.get(), ns, conn.topic, summary)
        if released is not None and stamp < released:
            summary.late_messages += 1
            continue
        heapq.heappush(heap, (stamp, seq, conn, msg))
        seq += 1
        while heap and heap[0][0] <= ns - window:
            stamp, _, c, m = heapq.heappop(heap)
            released = stamp
            yield c, stamp, m
    while heap:
        stamp, _, c, m = heapq.heappop(heap)
        yield c, stamp, m


def _header_stamp(msg: Any, log_ns: int, topic: str, summary: ConvertSummary) -> int:
    """`header.stamp` in ns (log time for a message without a header), counted per topic in `summary`."""
    stamp = getattr(getattr(msg, "header", None), "stamp", None)
    if stamp is None:
        return log_ns
    ns = int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)
    summary.header_stamps[topic] = summary.header_stamps.get(topic, 0) + 1
    summary.zero_stamps[topic] = summary.zero_stamps.get(topic, 0) + (ns == 0)
    return ns


def reward_value(msg: Any, mapping: Mapping, bag: Path) -> float:
    assert mapping.reward is not None
    where = f"{bag}: mapping: reward ({mapping.reward.topic}.{mapping.reward.field})"
    raw = field_value(msg, mapping.reward.field, where)
    if isinstance(raw, bool) or not isinstance(raw, (int, float, np.integer, np.floating)):
        raise BagError(f"{where}: field is {type(raw).__name__}, not a number", code="bag.field")
    value = float(raw)
    if not np.isfinite(value):
        raise BagError(f"{where}: non-finite reward {value}", code="bag.field")
    return value


def bool_value(msg: Any, mapping: Mapping, bag: Path) -> bool:
    assert mapping.success is not None and mapping.success.topic is not None
    where = f"{bag}: mapping: success ({mapping.success.topic}.{mapping.success.field})"
    raw = field_value(msg, mapping.success.field, where)
    if not isinstance(raw, (bool, np.bool_)):
        raise BagError(f"{where}: field is {type(raw).__name__}, not a bool", code="bag.field")
    return bool(raw)


def marker_event(msg: Any) -> dict[str, Any]:
    """Our `/openral/episode` JSON markers say start/end (+ success); any other marker message is a boundary."""
    data = getattr(msg, "data", None)
    if isinstance(data, str):
        try:
            parsed = parse_json(data)
        except ValueError:
            return {"event": data.strip().lower()}
        if isinstance(parsed, dict):
            return parsed
    return {"event": "boundary"}
