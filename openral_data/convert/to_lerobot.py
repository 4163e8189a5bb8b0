"""Bags -> LeRobot v3: stream each bag once, align the mapped topics to the target fps, write episodes with
our LeRobotV3Writer (through the DatasetBridge, so the contract checks of `record` apply). The dataset is
built in a hidden staging folder beside DST and renamed to DST at the end (`formats.staging`): a killed
convert leaves no partial dataset under DST, and the next run removes the dead run's staging folder.

Memory stays bounded: messages are read one at a time in time order, state/action are reduced to small
vectors on arrival, images stay serialised until the aligner picks them for a frame. A frame's images are then
deserialised and decoded in a small thread pool (Pillow and PyAV release the GIL, so decoding overlaps reading,
aligning and the writer's encoders) while the frames are handed to the writer strictly in order; at most
`DECODE_AHEAD` decoded frames wait, and the writer's encoder queue blocks when the encoder is behind.

Its parts: `preflight` (the bags checked before anything is written), `timed` (the messages in the order of the
aligning clock), `align` (messages -> frames on the fps grid), `writing` (frames -> episodes of the writer),
`summary` (what the run reports). `convert --workers N` (convert/parallel.py) runs `convert_bags` on blocks of
bags (`bags=`, `checks=False`) and merges the blocks in bag order.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from rosbags.interfaces import Connection

from openral_data.convert.preflight import CameraTopics, check_bags, check_outcome
from openral_data.convert.sources import find_bags, open_reader
from openral_data.convert.summary import ConvertSummary
from openral_data.convert.timed import bool_value, marker_event, reward_value, timed_messages
from openral_data.convert.writing import REWARD, Converter
from openral_data.formats.codec import Codec
from openral_data.formats.lerobot_v3.encoder import VideoSettings
from openral_data.formats.staging import Staging, check_new_output
from openral_data.schemas.mapping import Mapping

ProgressFn = Callable[[int, int], None]  # (messages read, messages in total)


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
    video: VideoSettings | None = None,
) -> ConvertSummary:
    """Convert the bags of `src` (or `bags`, a block of them: `src` then only names the source) into a new
    LeRobot v3 dataset at `dst`. `checks=False` (a block of `convert --workers`): a block without a single filled
    frame publishes nothing and returns its summary, and the header-stamp check is left to the caller, which
    makes both over all the blocks. `cameras`: what `check_bags` found over all the bags (a block then takes the
    first bag's camera intrinsics, as one process does). `carried_task`: the (time, text) a block's first bag
    starts with, as one process carries the previous bag's last task message into the next bag (`last_task`).
    `video`: the encoder settings (`codec` is the shorthand of `video.codec`), checked before anything is read."""
    settings = VideoSettings.given(codec, video=video)
    bags = find_bags(src) if bags is None else bags
    summary = ConvertSummary(src=src, dst=dst, bags=len(bags))
    wanted = mapping.topics()
    extra = [t for t in (mapping.task_topic, mapping.success_topic, mapping.episodes.marker_topic) if t is not None]
    cameras = CameraTopics() if cameras is None else cameras
    totals = check_bags(bags, mapping, summary, cameras)
    check_new_output(dst, "DST")
    staged = Staging(dst, "openral-data convert")  # DST appears complete or not at all
    with staged as staging:
        conv = Converter(mapping, staging, settings, summary, cameras, carried_task)
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


def _convert_bag(bag: Path, conv: Converter, wanted: list[str], extra: list[str]) -> Iterator[None]:
    mapping = conv.mapping
    split = mapping.episodes
    reader = open_reader(bag)
    try:
        conns: list[Connection] = [c for c in reader.connections if c.topic in wanted or c.topic in extra]
        aligner = conv.new_aligner()
        last_ns: int | None = None
        success: bool | None = None  # the latest `end` marker's verdict in this source episode
        info: dict[str, Any] | None = None  # and its episode info (our own bags': who drove)
        for conn, ns, msg in timed_messages(reader, bag, conns, mapping, conv.summary):
            yield None
            topic = conn.topic
            if topic == split.marker_topic:
                event = marker_event(msg.get())
                if event.get("event") == "end":
                    verdict, said = event.get("success"), event.get("info")
                    success = verdict if isinstance(verdict, bool) else None
                    info = said if isinstance(said, dict) else None
                if split.split == "marker" and event.get("event") != "start":
                    conv.finish_source_episode(aligner, success, info)
                    aligner, success, info = conv.new_aligner(), None, None
                continue
            if topic == mapping.task_topic:
                conv.note_task(ns, str(msg.get().data))
                continue
            if topic == mapping.success_topic:
                conv.note_success(ns, bool_value(msg.get(), mapping, bag))
                if topic not in conv.topic_streams:
                    continue  # else the same messages also carry aligned fields (reward, state, ...)
            if (
                split.split == "gap"
                and last_ns is not None
                and split.gap is not None
                and ns - last_ns > split.gap * 1e9
            ):
                conv.finish_source_episode(aligner, success, info)
                aligner, success, info = conv.new_aligner(), None, None
            last_ns = ns
            for stream in conv.topic_streams[topic]:
                part = conv.readers.get(stream)
                if part is not None:
                    payload: Any = part(msg.get(), bag)
                elif stream == REWARD:
                    payload = reward_value(msg.get(), mapping, bag)
                else:
                    payload = msg  # images stay serialised until a frame uses them
                for frame in aligner.push(stream, ns, payload):
                    conv.take(frame)
        conv.finish_source_episode(aligner, success, info)
    finally:
        conv.close_reader()  # no decoder thread still reads this bag's messages
        reader.close()
