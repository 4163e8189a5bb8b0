"""The mapped messages of a bag in the order of the clock the mapping aligns on (`timed_messages`), each
deserialised only when used (`Message`), and the values read from the reward, success and episode-marker topics."""

from __future__ import annotations

import heapq
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from PIL import Image as PILImage
from rosbags.interfaces import Connection

from openral_data.convert.camera_topics import decode_depth
from openral_data.convert.sources import BagReader, check_image, deserialize_trailing, field_value, read_messages
from openral_data.convert.summary import ConvertSummary
from openral_data.errors import BagError
from openral_data.formats.jsonfile import parse_json
from openral_data.formats.lerobot_v3.depth import DepthUnit
from openral_data.formats.mcap.foreign import Fields
from openral_data.formats.mcap.messages import decode_image
from openral_data.schemas.mapping import Mapping

_TRAILING = threading.Lock()  # messages are decoded in the Converter's decoder threads too


class Message:
    """A bag message, deserialised on first use (most multi-rate camera samples never are). A ROS 1 message
    with bytes after its last field is counted in `summary.trailing_bytes` under its topic."""

    __slots__ = ("_msg", "bag", "msgtype", "raw", "reader", "summary", "topic")

    def __init__(self, reader: BagReader, bag: Path, raw: bytes, conn: Connection, summary: ConvertSummary) -> None:
        self.reader, self.bag, self.raw, self.msgtype, self.topic = reader, bag, raw, conn.msgtype, conn.topic
        self.summary = summary
        self._msg: Any = None

    def get(self) -> Any:
        if self._msg is None:
            self._msg, trailing = deserialize_trailing(self.reader, self.bag, self.raw, self.msgtype)
            if trailing:
                with _TRAILING:
                    counts = self.summary.trailing_bytes
                    counts[self.topic] = counts.get(self.topic, 0) + 1
        return self._msg

    def decode(self) -> npt.NDArray[np.uint8]:
        msg = self.get()
        check_image(msg, self.msgtype, f"{self.bag}: {self.topic}")  # the first message was checked, not every one
        try:
            return decode_image(msg, self.msgtype)
        except (ValueError, OSError, PILImage.DecompressionBombError) as exc:  # UnidentifiedImageError: an OSError
            raise BagError(f"{self.bag}: {self.topic}: a message does not decode as an image: {exc}",
                           code="bag.invalid") from None  # fmt: skip

    def decode_depth(self, unit: DepthUnit) -> npt.NDArray[Any]:
        return decode_depth(self.get(), self.msgtype, unit, f"{self.bag}: {self.topic}")


# log time and header stamps this far apart at the first stamped message are two clocks (simulation time in
# the stamps, wall time in the log): messages without a header are then placed in the header time base
SEPARATE_CLOCKS_NS = 60 * 1_000_000_000


def timed_messages(
    reader: BagReader, bag: Path, conns: list[Connection], mapping: Mapping, summary: ConvertSummary
) -> Iterator[tuple[Connection, int, Message]]:
    """The mapped messages in the order of the clock the mapping aligns on.

    `log`: bag receive time, as stored. `header`: everything in the header time base, never compared with log
    time (the stamps may be simulation time in a wall-clock log): a message with a header is at its
    `header.stamp`; one without is at its log time when both clocks agree, else (stamps over a minute from their
    log time) at the latest stamped message's stamp plus the log time since it (`HeaderClock`). Stamps can lag
    one another (a camera stamps at exposure, the message is logged later), so messages are held in a heap
    until the newest time read is `align.reorder` seconds past them; a message older than one already released
    is late: it is counted in the summary and not used (never reordered into decided frames).
    """
    if mapping.align.clock == "log":
        for conn, ns, raw in read_messages(reader, bag, conns):
            yield conn, ns, Message(reader, bag, raw, conn, summary)
        return
    window = round(mapping.align.reorder * 1e9)
    heap: list[tuple[int, int, Connection, Message]] = []
    clock = HeaderClock()
    released: int | None = None
    newest: int | None = None
    seq = 0
    for conn, ns, raw in read_messages(reader, bag, conns):
        msg = Message(reader, bag, raw, conn, summary)
        for c, stamp, m in clock.place(conn, ns, msg, _header_stamp(msg.get(), conn.topic, summary)):
            if released is not None and stamp < released:
                summary.late_messages += 1
                continue
            heapq.heappush(heap, (stamp, seq, c, m))
            seq += 1
            newest = stamp if newest is None else max(newest, stamp)
            while heap and heap[0][0] <= newest - window:
                out, _, c2, m2 = heapq.heappop(heap)
                released = out
                yield c2, out, m2
    for c, stamp, m in clock.flush():
        heapq.heappush(heap, (stamp, seq, c, m))
        seq += 1
    while heap:
        stamp, _, c, m = heapq.heappop(heap)
        yield c, stamp, m


class HeaderClock:
    """Times in the header time base for `timed_messages`: a stamped message at its stamp; a message without a
    header at its log time if the stamps are on the log's clock, else at the latest stamp plus the log time
    elapsed since that stamped message was logged. Headerless messages before the first stamped one wait for it
    (which clock the stamps are on is unknown until then; a bag without stamps keeps log time)."""

    def __init__(self) -> None:
        self.offset: int | None = None  # log - stamp of the latest stamped message (0: the clocks agree)
        self.separate: bool | None = None
        self.waiting: list[tuple[Connection, int, Message]] = []

    def place(
        self, conn: Connection, log_ns: int, msg: Message, stamp: int | None
    ) -> Iterator[tuple[Connection, int, Message]]:
        if stamp is None:
            if self.separate is None:
                self.waiting.append((conn, log_ns, msg))
                return
            yield conn, log_ns - (self.offset or 0), msg
            return
        if self.separate is None:
            self.separate = abs(log_ns - stamp) > SEPARATE_CLOCKS_NS
        self.offset = log_ns - stamp if self.separate else 0
        waiting, self.waiting = self.waiting, []
        for c, ns, m in waiting:
            yield c, ns - self.offset, m
        yield conn, stamp, msg

    def flush(self) -> Iterator[tuple[Connection, int, Message]]:
        """Headerless messages still waiting at the end of the bag (no stamped message came): at log time."""
        waiting, self.waiting = self.waiting, []
        yield from waiting


def _header_stamp(msg: Any, topic: str, summary: ConvertSummary) -> int | None:
    """`header.stamp` in ns (None for a message without a header; a message of another MCAP profile: its own
    `timestamp` or ROS 1 header, `Fields.stamp_ns`), counted per topic in `summary`."""
    if isinstance(msg, Fields):
        own = msg.stamp_ns()
        if own is None:
            return None
        ns = own
    else:
        stamp = getattr(getattr(msg, "header", None), "stamp", None)
        if stamp is None:
            return None
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
    """Our `/openral/episode` JSON markers say start/end (+ success, and who drove: `info`); any other marker
    message is a boundary."""
    data = getattr(msg, "data", None)
    if isinstance(data, str):
        try:
            parsed = parse_json(data)
        except ValueError:
            return {"event": data.strip().lower()}
        if isinstance(parsed, dict):
            return parsed
    return {"event": "boundary"}
