"""Bags -> LeRobot v3: stream each bag once, align the mapped topics to the target fps, write episodes with
our LeRobotV3Writer (through the DatasetBridge, so the contract checks of `record` apply). The dataset is
built in a hidden staging folder beside DST and renamed to DST at the end (`formats.staging`): a killed
convert leaves no partial dataset under DST, and the next run removes the dead run's staging folder.

Memory stays bounded: messages are read one at a time in time order, state/action are reduced to small
vectors on arrival, images stay serialised until the aligner picks them for a frame. A frame's images are then
deserialised and decoded in a small thread pool (Pillow and PyAV release the GIL, so decoding overlaps reading,
aligning and the writer's encoders) while the frames are handed to the writer strictly in order; at most
`DECODE_AHEAD` decoded frames wait, and the writer's encoder queue blocks when the encoder is behind.

`convert --workers N` (convert/parallel.py) runs `convert_bags` on blocks of bags (`bags=`, `checks=False`)
and merges the blocks in bag order.
"""

from __future__ import annotations

import heapq
import json
import time
from collections import deque
from collections.abc import Callable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from rosbags.highlevel import AnyReader
from rosbags.interfaces import Connection

from openral_data.convert.align import AlignedFrame, Aligner
from openral_data.convert.camera_topics import check_depth_camera, check_info_size, decode_depth, read_camera_info
from openral_data.convert.sources import (
    VectorParts,
    VectorReader,
    check_camera,
    check_image,
    deserialize,
    field_value,
    find_bags,
    open_reader,
    read_messages,
)
from openral_data.errors import BagError
from openral_data.formats.lerobot_v3 import LeRobotV3Writer, VideoSettings, WriterConfig
from openral_data.formats.lerobot_v3.depth import DepthSettings, DepthUnit
from openral_data.formats.lerobot_v3.provenance import Origin
from openral_data.formats.lerobot_v3.video import Codec
from openral_data.formats.mcap.messages import decode_image
from openral_data.formats.staging import Staging, check_new_output
from openral_data.runtime.bridge import DatasetBridge
from openral_data.schemas.mapping import Mapping
from openral_data.types import CameraShape, DatasetSchema, EpisodeRecord, Observation
from openral_data.version import __version__

STATE, ACTION, ENV, REWARD = "state", "action", "environment_state", "reward"
ProgressFn = Callable[[int, int], None]  # (messages read, messages in total)
DECODE_THREADS = 2  # image decoding threads (JPEG/PNG via Pillow, raw via numpy)
DECODE_AHEAD = 8  # frames decoded ahead of the writer, at most (memory bound)


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
    late_messages: int = 0  # align.clock header: stamps further behind the log order than align.reorder
    header_stamps: dict[str, int] = field(default_factory=dict)  # align.clock header: topic -> stamped messages
    zero_stamps: dict[str, int] = field(default_factory=dict)  # ... of them with header.stamp 0
    source_episodes: int = 0  # source episodes seen (boundaries by the mapping's episodes.split)

    @property
    def fps(self) -> float:
        return self.frames / self.seconds if self.seconds > 0 else 0.0

    def to_json(self, mapping: Mapping, workers: int = 1, executor: str | None = None) -> dict[str, object]:
        """The fields of `convert --json` for bags -> LeRobot (made with `mapping`; `executor` None: one
        process), in docs/scripting.md's order."""
        return {
            "direction": "bags-to-lerobot",
            "source": str(self.src),
            "out": str(self.dst),
            "bags": self.bags,
            "episodes": len(self.episodes),
            "frames": self.frames,
            "fps": mapping.fps,
            "seconds": self.seconds,
            "frames_per_s": self.fps,
            "workers": workers,
            "executor": executor,
            "align_method": mapping.align.method,
            "align_clock": mapping.align.clock,
            "max_staleness_s": mapping.align.max_staleness,
            "topics": {t: asdict(r) for t, r in self.topics.items()},
            "unfillable_frames": self.unfillable_frames,
            "splits": self.splits,
            "empty_segments": self.empty_segments,
            "late_messages": self.late_messages if mapping.align.clock == "header" else None,
            "reward_topic": mapping.reward.topic if mapping.reward is not None else None,
            "success_topic": mapping.success.topic if mapping.success is not None else None,
            "success_markers": mapping.success is not None and mapping.success.marker,
            "skipped_topics": dict(sorted(self.skipped_topics.items())),
            "episode_list": [asdict(e) for e in self.episodes],
        }


@dataclass
class _Pending:
    frame: AlignedFrame[Any]
    task: str


@dataclass
class _Step:
    """A frame on its way to the writer: its images being decoded, the rest ready."""

    images: Future[dict[str, npt.NDArray[Any]]]
    obs: Observation
    action: npt.NDArray[np.float32]
    reward: float
    done: bool
    success: bool


@dataclass
class CameraTopics:
    """What the bags said about the cameras before conversion: depth units and CameraInfo intrinsics."""

    depth_units: dict[str, DepthUnit] = field(default_factory=dict)  # depth camera -> unit of its frames
    info: dict[str, dict[str, Any]] = field(default_factory=dict)  # camera -> intrinsics (camera_topics)


class _Converter:
    def __init__(
        self, mapping: Mapping, dst: Path, codec: Codec, summary: ConvertSummary, cameras: CameraTopics
    ) -> None:
        self.mapping = mapping
        self.dst = dst
        self.codec: Codec = codec
        self.summary = summary
        self.cameras = cameras
        # state, action and (when mapped) environment_state, each its parts' readers
        self.vectors = {role: VectorParts(role, vector) for role, vector in mapping.vectors()}
        # one aligned stream per vector part, camera and reward; a topic may feed several streams (state and
        # action from one JointState, each its own field): its messages are pushed to each of them
        self.vector_streams: dict[str, list[str]] = {}  # role -> its parts' streams, in order
        self.readers: dict[str, VectorReader] = {}  # vector stream -> its part's reader
        self.topic_streams: dict[str, list[str]] = {}
        for role, parts in self.vectors.items():
            for i, reader in enumerate(parts.readers):
                stream = f"{role}.{i}"
                self.vector_streams.setdefault(role, []).append(stream)
                self.readers[stream] = reader
                self.topic_streams.setdefault(reader.source.topic, []).append(stream)
        for name, topic in mapping.image_topics().items():
            self.topic_streams.setdefault(topic, []).append(name)
        if mapping.reward is not None:
            self.topic_streams.setdefault(mapping.reward.topic, []).append(REWARD)
        self.streams = [s for streams in self.topic_streams.values() for s in streams]
        self.bridge: DatasetBridge | None = None
        self.writer: LeRobotV3Writer | None = None
        self.camera_shapes: dict[str, CameraShape] = {}
        self.open = False
        self.pending: _Pending | None = None
        self.tasks: list[tuple[int, str]] = []
        self.successes: list[tuple[int, bool]] = []  # (time, value) on the success topic, oldest first
        self.source_episode = 0
        self.segment_frames = 0
        self.segment_start = 0
        self.decoder = ThreadPoolExecutor(DECODE_THREADS, thread_name_prefix="convert-decode")
        self.steps: deque[_Step] = deque()  # frames whose images are being decoded, in frame order

    # -- per source episode --------------------------------------------------------------------------------
    def new_aligner(self) -> Aligner[Any]:
        a = self.mapping.align
        return Aligner(self.streams, self.mapping.fps, a.method, a.max_staleness)

    def finish_source_episode(self, aligner: Aligner[Any], end_success: bool | None) -> None:
        """End of a source episode; `end_success` is its end marker's verdict (None: no marker / unknown)."""
        if not any(aligner.stats.received.values()):
            return  # nothing mapped arrived since the last boundary (e.g. the bag ends right after an end marker)
        for frame in aligner.finish():
            self.take(frame)
        self.close_segment(end_success, cut=False)
        if self.segment_frames == 0:
            self.summary.empty_segments += 1
        self.collect(aligner)
        self.source_episode += 1
        self.summary.source_episodes = self.source_episode
        self.segment_frames = 0
        self.tasks = self.tasks[-1:]
        self.successes = []  # a source episode's success starts unknown: never the previous episode's verdict

    def collect(self, aligner: Aligner[Any]) -> None:
        """Add a source episode's alignment stats to the per-topic report. The streams of one topic see the same
        samples at the same times under the same rule, so its first stream's stats are the topic's."""
        st = aligner.stats
        for topic, streams in self.topic_streams.items():
            s = streams[0]
            rep = self.summary.topics[topic]
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

    def success_at(self, t_ns: int) -> bool | None:
        """The success topic's latest value at `t_ns`; None before its first message."""
        while len(self.successes) > 1 and self.successes[1][0] <= t_ns:
            self.successes.pop(0)
        if self.successes and self.successes[0][0] <= t_ns:
            return self.successes[0][1]
        return None

    def take(self, frame: AlignedFrame[Any]) -> None:
        task = self.task_at(frame.time_ns)
        if frame.samples is None or task is None:
            self.summary.unfillable_frames += 1
            self.close_segment(None, cut=True)
            return
        if self.pending is not None:
            self.emit(self.pending, done=False, success=self.frame_success(self.pending, None))
        self.pending = _Pending(frame, task)

    def frame_success(self, pending: _Pending, episode_success: bool | None) -> bool:
        """next.success of a frame: the success topic's value, else (markers) the verdict on the last frame."""
        if self.mapping.success_topic is not None:
            return self.success_at(pending.frame.time_ns) is True
        return episode_success is True

    def episode_success(self, pending: _Pending, end_success: bool | None, cut: bool) -> bool | None:
        """A segment's success: the end marker's (None if a hole cut the segment before it), else the success
        topic's value at the last frame, else unknown."""
        source = self.mapping.success
        if source is None:
            return None
        if source.marker:
            return None if cut else end_success
        return self.success_at(pending.frame.time_ns)

    def vector(self, samples: dict[str, Any], role: str) -> npt.NDArray[np.float32]:
        """The role's vector of a frame: its parts' samples concatenated in the mapping's order."""
        parts = [samples[s] for s in self.vector_streams[role]]
        return parts[0] if len(parts) == 1 else np.concatenate(parts)

    def decode(self, samples: dict[str, Any]) -> dict[str, npt.NDArray[Any]]:
        """A frame's images (runs in a decoder thread)."""
        images: dict[str, npt.NDArray[Any]] = {name: samples[name].decode() for name in self.mapping.cameras}
        for name, unit in self.cameras.depth_units.items():
            images[name] = samples[name].decode_depth(unit)
        return images

    def emit(self, pending: _Pending, *, done: bool, success: bool) -> None:
        samples = pending.frame.samples
        assert samples is not None
        state, action = self.vector(samples, STATE), self.vector(samples, ACTION)
        env = self.vector(samples, ENV) if ENV in self.vectors else None
        images = self.decoder.submit(self.decode, samples)
        bridge = self.bridge if self.bridge is not None else self.ensure_writer(images.result())
        if not self.open:
            if self.segment_frames:  # this source episode already produced an episode: a hole split it
                self.summary.splits += 1
            bridge.begin_episode(self.source_episode, {"source_episode": self.source_episode})
            self.open = True
            self.segment_start = pending.frame.time_ns
        obs = Observation(
            images={},  # filled in by `flush` once decoded
            state=state,
            task=pending.task,
            time=(pending.frame.time_ns - self.segment_start) / 1e9,
            environment_state=env,
        )
        # without a reward source the schema has no reward column and the writer ignores this value
        reward = float(samples[REWARD]) if REWARD in samples else 0.0
        self.steps.append(_Step(images, obs, action, reward, done, success))
        self.segment_frames += 1
        self.flush(DECODE_AHEAD)

    def flush(self, keep: int = 0) -> None:
        """Hand decoded frames to the writer, oldest first, until at most `keep` are still on their way."""
        while len(self.steps) > keep:
            step = self.steps.popleft()
            step.obs.images = step.images.result()
            assert self.bridge is not None
            self.bridge.add_step(step.obs, step.action, reward=step.reward, done=step.done, success=step.success)

    def close_segment(self, end_success: bool | None, *, cut: bool) -> None:
        success: bool | None = None
        if self.pending is not None:
            success = self.episode_success(self.pending, end_success, cut)
            self.emit(self.pending, done=True, success=self.frame_success(self.pending, success))
            self.pending = None
        if self.open:
            assert self.bridge is not None
            self.flush()
            records = self.bridge.end_episode(success)
            self.summary.episodes.append(records[0])
            self.summary.frames += records[0].length
            self.open = False

    def camera_shape(self, name: str, img: npt.NDArray[Any]) -> CameraShape:
        h, w = int(img.shape[0]), int(img.shape[1])
        info = self.cameras.info.get(name)
        if info is None:
            return CameraShape(h, w, self.cameras.depth_units.get(name))
        topic = self.mapping.camera_info[name]
        check_info_size(info, h, w, f"{self.summary.src}: mapping: camera_info.{name} ({topic})")
        return CameraShape(h, w, self.cameras.depth_units.get(name), {"camera_info": info})

    def ensure_writer(self, images: dict[str, npt.NDArray[Any]]) -> DatasetBridge:
        if self.bridge is not None:
            return self.bridge
        schema = DatasetSchema(
            fps=self.mapping.fps,
            state_names=tuple(self.vectors[STATE].names()),
            action_names=tuple(self.vectors[ACTION].names()),
            environment_state_names=tuple(self.vectors[ENV].names()) if ENV in self.vectors else (),
            cameras={name: self.camera_shape(name, img) for name, img in images.items()},
            robot_type=self.mapping.robot_type,
            has_reward=self.mapping.reward is not None,
            has_success=self.mapping.success is not None,
            metadata=Origin(
                openral_data_version=__version__,
                converted_from=str(self.summary.src),
                mapping=self.mapping.model_dump(mode="json"),
            ).to_json(),
        )
        depth = DepthSettings(**self.mapping.depth.model_dump())
        self.writer = LeRobotV3Writer(
            self.dst, schema, WriterConfig(video=VideoSettings(codec=self.codec), depth=depth)
        )
        self.bridge = DatasetBridge(schema, [self.writer])
        return self.bridge

    def close_reader(self) -> None:
        """Wait for the decoder threads to be done with the bag being closed (after a failure: frames still on
        their way are dropped; nothing of this run is published)."""
        for step in self.steps:
            if not step.images.cancel():
                step.images.exception()  # wait; its error, if any, is not the one that stopped the run

    def close(self) -> None:
        for step in self.steps:
            step.images.cancel()  # only after a failure: a finished conversion flushed every frame
        self.decoder.shutdown(wait=True)
        if self.bridge is not None:
            self.bridge.close()


def convert_bags(
    src: Path,
    dst: Path,
    mapping: Mapping,
    *,
    codec: Codec = "av1",
    progress: ProgressFn | None = None,
    bags: list[Path] | None = None,
    checks: bool = True,
    cameras: CameraTopics | None = None,
    carried_task: tuple[int, str] | None = None,
) -> ConvertSummary:
    """Convert the bags of `src` (or `bags`, a block of them: `src` then only names the source) into a new
    LeRobot v3 dataset at `dst`. `checks=False` (a block of `convert --workers`): a block without a single filled
    frame publishes nothing and returns its summary, and the header-stamp check is left to the caller, which
    makes both over all the blocks. `cameras`: what `check_bags` found over all the bags (a block then takes the
    first bag's camera intrinsics, as one process does). `carried_task`: the (time, text) a block's first bag
    starts with, as one process carries the previous bag's last task message into the next bag (`last_task`)."""
    bags = find_bags(src) if bags is None else bags
    summary = ConvertSummary(src=src, dst=dst, bags=len(bags))
    wanted = mapping.topics()
    extra = [t for t in (mapping.task_topic, mapping.success_topic, mapping.episodes.marker_topic) if t is not None]
    cameras = CameraTopics() if cameras is None else cameras
    totals = check_bags(bags, mapping, summary, cameras)
    check_new_output(dst, "DST")
    staged = Staging(dst, "openral-data convert")  # DST appears complete or not at all
    with staged as staging:
        conv = _Converter(mapping, staging, codec, summary, cameras)
        if carried_task is not None:
            conv.tasks = [carried_task]
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
        if not checks and not summary.episodes:
            return summary  # the staging folder goes: nothing is published
        if checks:
            check_outcome(summary)
        staged.publish("DST")
    return summary


def check_bags(bags: list[Path], mapping: Mapping, summary: ConvertSummary, cameras: CameraTopics) -> int:
    """Every mapped topic exists in every bag, with the cameras' types: checked up front, before anything is
    written. Fills the summary's topic reports and skipped topics, and `cameras`; returns the mapped messages."""
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
    reader: AnyReader, bag: Path, mapping: Mapping, conn: dict[str, Connection], cameras: CameraTopics
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


def _convert_bag(bag: Path, conv: _Converter, wanted: list[str], extra: list[str]) -> Iterator[None]:
    mapping = conv.mapping
    split = mapping.episodes
    reader = open_reader(bag)
    try:
        conns: list[Connection] = [c for c in reader.connections if c.topic in wanted or c.topic in extra]
        aligner = conv.new_aligner()
        last_ns: int | None = None
        success: bool | None = None  # the latest `end` marker's verdict in this source episode
        for conn, ns, msg in _timed_messages(reader, bag, conns, mapping, conv.summary):
            yield None
            topic = conn.topic
            if topic == split.marker_topic:
                event = _marker_event(msg.get())
                if event.get("event") == "end":
                    verdict = event.get("success")
                    success = verdict if isinstance(verdict, bool) else None
                if split.split == "marker" and event.get("event") != "start":
                    conv.finish_source_episode(aligner, success)
                    aligner, success = conv.new_aligner(), None
                continue
            if topic == mapping.task_topic:
                conv.tasks.append((ns, str(msg.get().data)))
                continue
            if topic == mapping.success_topic:
                conv.successes.append((ns, _bool_value(msg.get(), mapping, bag)))
                if topic not in conv.topic_streams:
                    continue  # else the same messages also carry aligned fields (reward, state, ...)
            if (
                split.split == "gap"
                and last_ns is not None
                and split.gap is not None
                and ns - last_ns > split.gap * 1e9
            ):
                conv.finish_source_episode(aligner, success)
                aligner, success = conv.new_aligner(), None
            last_ns = ns
            for stream in conv.topic_streams[topic]:
                part = conv.readers.get(stream)
                if part is not None:
                    payload: Any = part(msg.get(), bag)
                elif stream == REWARD:
                    payload = _reward_value(msg.get(), mapping, bag)
                else:
                    payload = msg  # images stay serialised until a frame uses them
                for frame in aligner.push(stream, ns, payload):
                    conv.take(frame)
        conv.finish_source_episode(aligner, success)
    finally:
        conv.close_reader()  # no decoder thread still reads this bag's messages
        reader.close()


class _Message:
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


def _timed_messages(
    reader: AnyReader, bag: Path, conns: list[Connection], mapping: Mapping, summary: ConvertSummary
) -> Iterator[tuple[Connection, int, _Message]]:
    """The mapped messages in the order of the clock the mapping aligns on.

    `log`: bag receive time, as stored. `header`: `header.stamp` for messages that have a header (log time for
    the others). Stamps can lag the log order (a camera stamps at exposure, the message is logged later), so
    messages are held in a heap for `align.reorder` seconds of log time; a message whose stamp is older than one
    already released is late: it is counted in the summary and not used (never reordered into decided frames).
    """
    if mapping.align.clock == "log":
        for conn, ns, raw in read_messages(reader, bag, conns):
            yield conn, ns, _Message(reader, bag, raw, conn)
        return
    window = round(mapping.align.reorder * 1e9)
    heap: list[tuple[int, int, Connection, _Message]] = []
    released: int | None = None
    seq = 0
    for conn, ns, raw in read_messages(reader, bag, conns):
        msg = _Message(reader, bag, raw, conn)
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


def _reward_value(msg: Any, mapping: Mapping, bag: Path) -> float:
    assert mapping.reward is not None
    where = f"{bag}: mapping: reward ({mapping.reward.topic}.{mapping.reward.field})"
    raw = field_value(msg, mapping.reward.field, where)
    if isinstance(raw, bool) or not isinstance(raw, (int, float, np.integer, np.floating)):
        raise BagError(f"{where}: field is {type(raw).__name__}, not a number", code="bag.field")
    value = float(raw)
    if not np.isfinite(value):
        raise BagError(f"{where}: non-finite reward {value}", code="bag.field")
    return value


def _bool_value(msg: Any, mapping: Mapping, bag: Path) -> bool:
    assert mapping.success is not None and mapping.success.topic is not None
    where = f"{bag}: mapping: success ({mapping.success.topic}.{mapping.success.field})"
    raw = field_value(msg, mapping.success.field, where)
    if not isinstance(raw, (bool, np.bool_)):
        raise BagError(f"{where}: field is {type(raw).__name__}, not a bool", code="bag.field")
    return bool(raw)


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
