"""What a bags -> LeRobot conversion reads from the bags before it writes anything: every mapped topic there with
its cameras' types (`check_bags`, which also counts the messages and finds depth units and camera intrinsics,
`CameraTopics`), the task text a bag ends with (`last_task`), and the refusal of a run that filled no frame
(`check_outcome`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rosbags.interfaces import Connection

from openral_data.convert.camera_topics import check_depth_camera, read_camera_info
from openral_data.convert.sources import BagReader, check_camera, deserialize, open_reader, read_messages
from openral_data.convert.summary import ConvertSummary, TopicReport
from openral_data.errors import BagError, ConfigError
from openral_data.formats.lerobot_v3.depth import DepthUnit
from openral_data.schemas.mapping import Mapping


@dataclass
class CameraTopics:
    """What the bags said about the cameras before conversion: depth units and CameraInfo intrinsics."""

    depth_units: dict[str, DepthUnit] = field(default_factory=dict)  # depth camera -> unit of its frames
    info: dict[str, dict[str, Any]] = field(default_factory=dict)  # camera -> intrinsics (camera_topics)


def check_bags(bags: list[Path], mapping: Mapping, summary: ConvertSummary, cameras: CameraTopics) -> int:
    """Every mapped topic exists in every bag, with the cameras' types: checked up front, before anything is
    written. Fills the summary's topic reports and skipped topics, and `cameras`; returns the mapped messages."""
    for role, vector in mapping.vectors():
        for label, source in zip(vector.labels(), vector.sources(), strict=True):
            if source.offset:
                where = f"{role}.{label}.offset" if label else f"{role}.offset"
                raise ConfigError(f"{bags[0]}: {where}: array sources only (a bag's streams align by time)")
    wanted = mapping.topics()
    extra = [t for t in (mapping.task_topic, mapping.success_topic, mapping.episodes.marker_topic) if t is not None]
    info_topics = list(mapping.camera_info.values())  # read up front (first message), not aligned
    totals = 0
    for bag in bags:
        reader = open_reader(bag)
        try:
            present = {c.topic: c.msgtype for c in reader.connections}
            missing = [t for t in wanted + extra + info_topics if t not in present]
            if missing:
                raise BagError(
                    f"{bag}: mapped topic(s) {', '.join(missing)} not in the bag "
                    f"(topics: {', '.join(sorted(present))})",
                    code="bag.topic",
                )
            for c in reader.connections:
                if c.topic in wanted or c.topic in extra:
                    totals += c.msgcount
                elif c.topic not in info_topics:
                    summary.skipped_topics[c.topic] = summary.skipped_topics.get(c.topic, 0) + c.msgcount
            for t in wanted:
                summary.topics.setdefault(t, TopicReport(t, present[t]))
            conn = {c.topic: c for c in reader.connections}
            for name, topic in mapping.cameras.items():
                check_camera(reader, bag, name, conn[topic])
            _check_depth_cameras(reader, bag, mapping, conn, cameras)
            for name, topic in mapping.camera_info.items():
                cameras.info.setdefault(name, read_camera_info(reader, bag, name, conn[topic]))
        finally:
            reader.close()
    return totals


def last_task(bag: Path, mapping: Mapping) -> tuple[int, str] | None:
    """The bag's last message on the mapping's `task_topic` as (time, text): what one process carries into the
    next bag's frames until that bag's own first task message. None: no task topic, or no message on it."""
    if mapping.task is not None or mapping.task_topic is None:
        return None
    reader = open_reader(bag)
    try:
        conns = [c for c in reader.connections if c.topic == mapping.task_topic]
        last: tuple[int, str] | None = None
        for conn, ns, raw in read_messages(reader, bag, conns):
            # a String has no header: its time is its log time with either align.clock, and log order is its order
            last = (ns, str(deserialize(reader, bag, raw, conn.msgtype).data))
        return last
    finally:
        reader.close()


def check_outcome(summary: ConvertSummary) -> None:
    """Refuse a conversion that filled no frame, or aligned on header stamps that are all zero."""
    _check_stamps(summary.src, summary)
    if not summary.episodes:
        raise BagError(
            f"{summary.src}: no frame could be filled; nothing was written (see the mapping's align settings)",
            code="bag.empty",
        )


def _check_depth_cameras(
    reader: BagReader, bag: Path, mapping: Mapping, conn: dict[str, Connection], cameras: CameraTopics
) -> None:
    """Each depth camera carries 16UC1 or 32FC1, the same in every bag."""
    for name, topic in mapping.depth_cameras.items():
        unit = check_depth_camera(reader, bag, name, conn[topic])
        if cameras.depth_units.setdefault(name, unit) != unit:
            raise BagError(
                f"{bag}: mapping: depth_cameras.{name} ({topic}): depth in {unit} here, "
                f"in {cameras.depth_units[name]} in an earlier bag",
                code="bag.type",
            )


def _check_stamps(src: Path, summary: ConvertSummary) -> None:
    """`align.clock: header` on a topic whose header stamps are all zero (a driver that never sets them) puts
    every message at the epoch: one line naming the topic, before anything is published."""
    zero = [t for t, n in summary.header_stamps.items() if n and summary.zero_stamps.get(t, 0) == n]
    if zero:
        raise BagError(
            f"{src}: {zero[0]}: header stamps are all zero, so align.clock: header cannot place its messages; "
            "nothing was written (set align.clock: log in the mapping to align on receive time)",
            code="bag.empty",
        )
