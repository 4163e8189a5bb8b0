"""Bags -> LeRobot v3: stream each bag once, align the mapped topics to the target fps, write episodes with
our LeRobotV3Writer (through the DatasetBridge, so the contract checks of `record` apply).

Memory stays bounded: messages are read one at a time in time order, state/action are reduced to small
vectors on arrival, images stay serialised until the aligner picks them for a frame and are then decoded
and handed to the writer's encoder queue (which blocks when the encoder is behind).
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from rosbags.highlevel import AnyReader, AnyReaderError
from rosbags.interfaces import Connection
from rosbags.typesys import Stores, get_typestore

from openral_data import __version__
from openral_data.bridge import DatasetBridge
from openral_data.convert.align import AlignedFrame, Aligner
from openral_data.convert.sources import VectorReader, find_bags
from openral_data.errors import OpenralError
from openral_data.producers.base import CameraShape, Observation
from openral_data.schemas.mapping import Mapping
from openral_data.sinks.base import DatasetSchema, EpisodeRecord
from openral_data.sinks.lerobot_v3 import LeRobotV3Writer, VideoSettings, WriterConfig
from openral_data.sinks.lerobot_v3.video import Codec
from openral_data.sinks.mcap.messages import decode_image

STATE, ACTION = "state", "action"
ProgressFn = Callable[[int, int], None]  # (messages read, messages in total)


@dataclass
class TopicReport:
    topic: str
    msgtype: str
    messages: int = 0
    used: int = 0  # samples that went into at least one frame
    unused: int = 0  # superseded by a later/nearer sample, or outside every frame's window
    unfillable_frames: int = 0  # grid frames this topic had no sample for within max_staleness


@dataclass
class ConvertSummary:
    src: Path
    dst: Path
    bags: int = 0
    episodes: list[EpisodeRecord] = field(default_factory=list)
    frames: int = 0
    seconds: float = 0.0
    topics: dict[str, TopicReport] = field(default_factory=dict)
    skipped_topics: dict[str, int] = field(default_factory=dict)  # unmapped topic -> messages not read
    unfillable_frames: int = 0
    splits: int = 0  # extra episodes started because unfillable frames interrupted a source episode
    empty_segments: int = 0  # source episodes in which no frame could be filled

    @property
    def fps(self) -> float:
        return self.frames / self.seconds if self.seconds > 0 else 0.0


@dataclass
class _Pending:
    frame: AlignedFrame[Any]
    task: str


class _Converter:
    def __init__(self, mapping: Mapping, dst: Path, codec: Codec, summary: ConvertSummary) -> None:
        self.mapping = mapping
        self.dst = dst
        self.codec: Codec = codec
        self.summary = summary
        self.state = VectorReader(mapping.state, "state")
        self.action = VectorReader(mapping.action, "action")
        self.streams = [STATE, ACTION, *mapping.cameras]
        self.topic_stream = {mapping.state.topic: STATE, mapping.action.topic: ACTION}
        self.topic_stream.update({topic: name for name, topic in mapping.cameras.items()})
        self.stream_topic = {s: t for t, s in self.topic_stream.items()}
        self.bridge: DatasetBridge | None = None
        self.writer: LeRobotV3Writer | None = None
        self.camera_shapes: dict[str, CameraShape] = {}
        self.open = False
        self.pending: _Pending | None = None
        self.tasks: list[tuple[int, str]] = []
        self.source_episode = 0
        self.segment_frames = 0
        self.segment_start = 0

    # -- per source episode --------------------------------------------------------------------------------
    def new_aligner(self) -> Aligner[Any]:
        a = self.mapping.align
        return Aligner(self.streams, self.mapping.fps, a.method, a.max_staleness)

    def finish_source_episode(self, aligner: Aligner[Any], success: bool) -> None:
        if not any(aligner.stats.received.values()):
            return  # nothing mapped arrived since the last boundary (e.g. the bag ends right after an end marker)
        for frame in aligner.finish():
            self.take(frame)
        self.close_segment(success)
        if self.segment_frames == 0:
            self.summary.empty_segments += 1
        self.collect(aligner)
        self.source_episode += 1
        self.segment_frames = 0
        self.tasks = self.tasks[-1:]

    def collect(self, aligner: Aligner[Any]) -> None:
        st = aligner.stats
        for s in self.streams:
            rep = self.summary.topics[self.stream_topic[s]]
            rep.messages += st.received.get(s, 0)
            rep.unused += st.unused.get(s, 0)
            rep.used += st.received.get(s, 0) - st.unused.get(s, 0)
            rep.unfillable_frames += st.unfillable.get(s, 0)

    # -- frames --------------------------------------------------------------------------------------------
    def task_at(self, t_ns: int) -> str | None:
        if self.mapping.task is not None:
            return self.mapping.task
        while len(self.tasks) > 1 and self.tasks[1][0] <= t_ns:
            self.tasks.pop(0)  # frames are decided in time order: older task texts are never needed again
        if self.tasks and self.tasks[0][0] <= t_ns:
            return self.tasks[0][1]
        return None

    def take(self, frame: AlignedFrame[Any]) -> None:
        task = self.task_at(frame.time_ns)
        if frame.samples is None or task is None:
            self.summary.unfillable_frames += 1
            self.close_segment(False)
            return
        if self.pending is not None:
            self.emit(self.pending, done=False, success=False)
        self.pending = _Pending(frame, task)

    def emit(self, pending: _Pending, *, done: bool, success: bool) -> None:
        samples = pending.frame.samples
        assert samples is not None
        images = {name: samples[name].decode() for name in self.mapping.cameras}
        bridge = self.ensure_writer(images, samples[STATE], samples[ACTION])
        if not self.open:
            if self.segment_frames:  # this source episode already produced an episode: a hole split it
                self.summary.splits += 1
            bridge.begin_episode(self.source_episode, {"source_episode": self.source_episode})
            self.open = True
            self.segment_start = pending.frame.time_ns
        obs = Observation(
            images=images,
            state=samples[STATE],
            task=pending.task,
            time=(pending.frame.time_ns - self.segment_start) / 1e9,
        )
        bridge.add_step(obs, samples[ACTION], reward=0.0, done=done, success=success)
        self.segment_frames += 1

    def close_segment(self, success: bool) -> None:
        if self.pending is not None:
            self.emit(self.pending, done=True, success=success)
            self.pending = None
        if self.open:
            assert self.bridge is not None
            records = self.bridge.end_episode(success)
            self.summary.episodes.append(records[0])
            self.summary.frames += records[0].length
            self.open = False

    def ensure_writer(
        self,
        images: dict[str, npt.NDArray[np.uint8]],
        state: npt.NDArray[np.float32],
        action: npt.NDArray[np.float32],
    ) -> DatasetBridge:
        if self.bridge is not None:
            return self.bridge
        schema = DatasetSchema(
            fps=self.mapping.fps,
            state_names=tuple(self.state.names()),
            action_names=tuple(self.action.names()),
            cameras={name: CameraShape(int(img.shape[0]), int(img.shape[1])) for name, img in images.items()},
            robot_type=self.mapping.robot_type,
            metadata={
                "openral_data_version": __version__,
                "converted_from": str(self.summary.src),
                "mapping": self.mapping.model_dump(mode="json"),
            },
        )
        self.writer = LeRobotV3Writer(self.dst, schema, WriterConfig(video=VideoSettings(codec=self.codec)))
        self.bridge = DatasetBridge(schema, [self.writer])
        return self.bridge

    def close(self) -> None:
        if self.bridge is not None:
            self.bridge.close()


def _open_reader(bag: Path) -> AnyReader:
    store = get_typestore(Stores.ROS1_NOETIC if bag.suffix == ".bag" else Stores.ROS2_HUMBLE)
    reader = AnyReader([bag], default_typestore=store)
    try:
        reader.open()
    except (AnyReaderError, OSError, ValueError) as exc:
        raise OpenralError(f"{bag}: cannot read bag: {exc}") from None
    return reader


def convert_bags(
    src: Path,
    dst: Path,
    mapping: Mapping,
    *,
    codec: Codec = "av1",
    progress: ProgressFn | None = None,
) -> ConvertSummary:
    bags = find_bags(src)
    summary = ConvertSummary(src=src, dst=dst, bags=len(bags))
    wanted = mapping.topics()
    extra = [t for t in (mapping.task_topic, mapping.episodes.marker_topic) if t is not None]
    # every mapped topic must exist in every bag: checked up front, before anything is written
    totals = 0
    for bag in bags:
        reader = _open_reader(bag)
        try:
            present = {c.topic: c.msgtype for c in reader.connections}
            missing = [t for t in wanted + extra if t not in present]
            if missing:
                raise OpenralError(
                    f"{bag}: mapped topic(s) {', '.join(missing)} not in the bag (topics: {', '.join(sorted(present))})"
                )
            for c in reader.connections:
                if c.topic in wanted or c.topic in extra:
                    totals += c.msgcount
                else:
                    summary.skipped_topics[c.topic] = summary.skipped_topics.get(c.topic, 0) + c.msgcount
            for t in wanted:
                summary.topics.setdefault(t, TopicReport(t, present[t]))
        finally:
            reader.close()
    conv = _Converter(mapping, dst, codec, summary)
    t0 = time.perf_counter()
    done = 0
    try:
        for bag in bags:
            for _ in _convert_bag(bag, conv, wanted, extra):
                done += 1
                if progress is not None and done % 64 == 0:
                    progress(done, totals)
        if progress is not None:
            progress(totals, totals)
    finally:
        conv.close()
    summary.seconds = time.perf_counter() - t0
    if not summary.episodes:
        raise OpenralError(f"{src}: no frame could be filled; nothing was written (see the mapping's align settings)")
    return summary


def _convert_bag(bag: Path, conv: _Converter, wanted: list[str], extra: list[str]) -> Iterator[None]:
    mapping = conv.mapping
    split = mapping.episodes
    reader = _open_reader(bag)
    try:
        conns: list[Connection] = [c for c in reader.connections if c.topic in wanted or c.topic in extra]
        aligner = conv.new_aligner()
        last_ns: int | None = None
        success = False  # from an `end` marker (our bags), else unknown = False
        for conn, ns, raw in reader.messages(connections=conns):
            yield None
            topic = conn.topic
            if topic == split.marker_topic:
                event = _marker_event(reader.deserialize(raw, conn.msgtype))
                if event.get("event") == "end":
                    success = bool(event.get("success", False))
                if split.split == "marker" and event.get("event") != "start":
                    conv.finish_source_episode(aligner, success)
                    aligner, success = conv.new_aligner(), False
                continue
            if topic == mapping.task_topic:
                conv.tasks.append((ns, str(reader.deserialize(raw, conn.msgtype).data)))  # type: ignore[attr-defined]
                continue
            if (
                split.split == "gap"
                and last_ns is not None
                and split.gap is not None
                and ns - last_ns > split.gap * 1e9
            ):
                conv.finish_source_episode(aligner, success)
                aligner, success = conv.new_aligner(), False
            last_ns = ns
            stream = conv.topic_stream[topic]
            if stream == STATE:
                payload: Any = conv.state(reader.deserialize(raw, conn.msgtype))
            elif stream == ACTION:
                payload = conv.action(reader.deserialize(raw, conn.msgtype))
            else:
                payload = _RawImage(reader, raw, conn.msgtype)
            for frame in aligner.push(stream, ns, payload):
                conv.take(frame)
        conv.finish_source_episode(aligner, success)
    finally:
        reader.close()


@dataclass(frozen=True)
class _RawImage:
    """A camera message kept serialised until a frame uses it (most multi-rate samples never are)."""

    reader: AnyReader
    raw: bytes
    msgtype: str

    def decode(self) -> npt.NDArray[np.uint8]:
        return decode_image(self.reader.deserialize(self.raw, self.msgtype), self.msgtype)


def _marker_event(msg: Any) -> dict[str, Any]:
    """Our `/openral/episode` JSON markers say start/end (+ success); any other marker message is a boundary."""
    data = getattr(msg, "data", None)
    if isinstance(data, str):
        try:
            parsed = json.loads(data)
        except json.JSONDecodeError:
            return {"event": data.strip().lower()}
        if isinstance(parsed, dict):
            return parsed
    return {"event": "boundary"}
