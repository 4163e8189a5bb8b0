"""Aligned frames -> episodes of our LeRobotV3Writer (through the DatasetBridge): `Converter` cuts the frames into
episodes (source episodes, split by holes), fills task, reward and success, builds the dataset schema from the
first frame and decodes the frames' images in a small thread pool while handing them to the writer in order."""

from __future__ import annotations

from collections import deque
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from openral_data.columns import POLICY_ACTION
from openral_data.convert.align import AlignedFrame, Aligner
from openral_data.convert.camera_topics import check_info_size
from openral_data.convert.preflight import CameraTopics
from openral_data.convert.sources import VectorParts, VectorReader
from openral_data.convert.summary import ConvertSummary
from openral_data.errors import BagError
from openral_data.formats.lerobot_v3 import LeRobotV3Writer, VideoSettings, WriterConfig
from openral_data.formats.lerobot_v3.depth import DepthSettings
from openral_data.formats.lerobot_v3.provenance import Origin
from openral_data.runtime.bridge import DatasetBridge
from openral_data.schemas.mapping import Mapping
from openral_data.types import CameraShape, DatasetSchema, FrameColumn, Observation
from openral_data.version import __version__

STATE, ACTION, ENV, REWARD = "state", "action", "environment_state", "reward"
DECODE_THREADS = 2  # image decoding threads (JPEG/PNG via Pillow, raw via numpy)
DECODE_AHEAD = 8  # frames decoded ahead of the writer, at most (memory bound)


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
    columns: dict[str, Any]


class Converter:
    """One conversion's frames on their way into the dataset at `dst` (see the module)."""

    def __init__(
        self,
        mapping: Mapping,
        dst: Path,
        video: VideoSettings,
        summary: ConvertSummary,
        cameras: CameraTopics,
        carried_task: tuple[int, str] | None = None,
    ) -> None:
        self.mapping = mapping
        self.dst = dst
        self.video = video  # resolved and checked (`VideoSettings.given`)
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
        # the mapping's extra per-frame columns, each one aligned stream read as a vector (a flag as one number)
        self.column_streams = {key: f"columns.{key}" for key in mapping.columns}
        for key, column in mapping.columns.items():
            stream = self.column_streams[key]
            self.readers[stream] = VectorReader(column.vector_source(), f"columns.{key}")
            self.topic_streams.setdefault(column.topic, []).append(stream)
        self.streams = [s for streams in self.topic_streams.values() for s in streams]
        self.bridge: DatasetBridge | None = None
        self.writer: LeRobotV3Writer | None = None
        self.camera_shapes: dict[str, CameraShape] = {}
        self.open = False
        self.pending: _Pending | None = None
        self.tasks: list[tuple[int, str]] = [carried_task] if carried_task is not None else []
        self.successes: list[tuple[int, bool]] = []  # (time, value) on the success topic, oldest first
        self.episode_start: dict[str, Any] = {}  # more of the source episode's initial_state (its split)
        self.source_episode = 0
        self.segment_frames = 0
        self.segment_start = 0
        self.decoder = ThreadPoolExecutor(DECODE_THREADS, thread_name_prefix="convert-decode")
        self.steps: deque[_Step] = deque()  # frames whose images are being decoded, in frame order

    # -- per source episode --------------------------------------------------------------------------------
    def note_task(self, t_ns: int, text: str) -> None:
        """The task text from time `t_ns` on (a task message)."""
        self.tasks.append((t_ns, text))

    def note_success(self, t_ns: int, value: bool) -> None:
        """The success signal's value from time `t_ns` on."""
        self.successes.append((t_ns, value))

    def start_source_episode(self, task: str, start: dict[str, Any] | None = None) -> None:
        """An array source's episode begins: its own task text from its first frame, its success unknown yet;
        `start` goes into its initial_state (a source split, RLDS or robomimic filter keys: info.json's splits)."""
        self.tasks = [(0, task)]
        self.successes = []
        self.episode_start = dict(start or {})

    def new_aligner(self) -> Aligner[Any]:
        a = self.mapping.align
        return Aligner(self.streams, self.mapping.fps, a.method, a.max_staleness)

    def finish_source_episode(
        self, aligner: Aligner[Any], end_success: bool | None, info: dict[str, Any] | None = None
    ) -> None:
        """End of a source episode; `end_success` is its end marker's verdict (None: no marker / unknown), `info`
        its end marker's episode info (who drove: our own bags'), kept as the last segment's."""
        if not any(aligner.stats.received.values()):
            return  # nothing mapped arrived since the last boundary (e.g. the bag ends right after an end marker)
        for frame in aligner.finish():
            self.take(frame)
        self.collect(aligner)
        self.end_source_episode(end_success, info)

    def end_source_episode(self, end_success: bool | None, info: dict[str, Any] | None = None) -> None:
        """The source episode's last frame was taken: close its segment and start the next source episode
        (array sources, whose steps are frames, call it directly)."""
        self.close_segment(end_success, cut=False, info=info)
        if self.segment_frames == 0:
            self.summary.empty_segments += 1
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
        if self.mapping.image_origin == "bottom":  # stored bottom row first (an OpenGL read-back): made upright
            images = {name: np.ascontiguousarray(img[::-1]) for name, img in images.items()}
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
            bridge.begin_episode(self.source_episode, {"source_episode": self.source_episode, **self.episode_start})
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
        columns = {key: self.column_value(key, samples[stream]) for key, stream in self.column_streams.items()}
        self.steps.append(_Step(images, obs, action, reward, done, success, columns))
        self.segment_frames += 1
        self.flush(DECODE_AHEAD)

    def flush(self, keep: int = 0) -> None:
        """Hand decoded frames to the writer, oldest first, until at most `keep` are still on their way."""
        while len(self.steps) > keep:
            step = self.steps.popleft()
            step.obs.images = step.images.result()
            assert self.bridge is not None
            self.bridge.add_step(
                step.obs, step.action, reward=step.reward, done=step.done, success=step.success, columns=step.columns
            )

    def column_value(self, key: str, sample: npt.NDArray[np.float32]) -> Any:
        """A column's value of a frame: the vector, or a flag's one number as a bool."""
        if self.mapping.columns[key].dtype == "float32":
            return sample
        if sample.shape != (1,):
            raise BagError(f"{self.summary.src}: mapping: columns.{key}: {sample.shape[0]} values for one flag",
                           code="bag.field")  # fmt: skip
        return bool(sample[0])

    def close_segment(self, end_success: bool | None, *, cut: bool, info: dict[str, Any] | None = None) -> None:
        success: bool | None = None
        if self.pending is not None:
            success = self.episode_success(self.pending, end_success, cut)
            self.emit(self.pending, done=True, success=self.frame_success(self.pending, success))
            self.pending = None
        if self.open:
            assert self.bridge is not None
            self.flush()
            records = self.bridge.end_episode(success, info)
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
        action_names = tuple(self.vectors[ACTION].names())
        proposal = self.column_streams.get(POLICY_ACTION)
        if proposal is not None and len(self.readers[proposal].names()) != len(action_names):
            raise BagError(f"{self.summary.src}: mapping: columns.{POLICY_ACTION}: "
                           f"{len(self.readers[proposal].names())} dimensions, the action has {len(action_names)}",
                           code="bag.field")  # fmt: skip
        schema = DatasetSchema(
            fps=self.mapping.fps,
            state_names=tuple(self.vectors[STATE].names()),
            action_names=action_names,
            environment_state_names=tuple(self.vectors[ENV].names()) if ENV in self.vectors else (),
            cameras={name: self.camera_shape(name, img) for name, img in images.items()},
            robot_type=self.mapping.robot_type,
            has_reward=self.mapping.reward is not None,
            has_success=self.mapping.success is not None,
            frame_columns=tuple(
                FrameColumn(key, "float32", tuple(self.readers[stream].names()))
                if self.mapping.columns[key].dtype == "float32"
                else FrameColumn(key, "bool")
                for key, stream in self.column_streams.items()
            ),
            metadata=Origin(
                openral_data_version=__version__,
                converted_from=str(self.summary.src),
                mapping=self.mapping.model_dump(mode="json"),
            ).to_json(),
        )
        depth = DepthSettings(**self.mapping.depth.model_dump())
        self.writer = LeRobotV3Writer(self.dst, schema, WriterConfig(video=self.video, depth=depth))
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
