"""Array sources (HDF5, Zarr, RLDS: `formats.episodic`) -> LeRobot v3 through the same `Converter`, DatasetBridge
and LeRobotV3Writer as bags. A source's steps are already frames (no aligner): step k of an episode is frame k
at k / fps. Each episode is read in chunks of rows (`CHUNK_BYTES` of decoded data across the mapped arrays), so
memory is bounded by a chunk and the frames the writer holds, never by a file.

The mapping's roles name array keys (`convert.array_mapping`); every mapped key is checked on each episode before
its first row is read (present, numbers or pictures, the width the names say) and every vector, reward and
success value is checked finite as it is read: a bad one is one line naming the file, the episode and the key.
A vector part with `offset: N` takes, at step t, the array's step t + N (the episode's last step once past it):
e.g. an action that is the next step's pose, for sources that record no command.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from openral_data.convert.align import AlignedFrame
from openral_data.convert.array_mapping import LANGUAGE, is_picture, is_vector
from openral_data.convert.preflight import CameraTopics, check_outcome
from openral_data.convert.summary import ConvertSummary, TopicReport
from openral_data.convert.writing import REWARD, Converter
from openral_data.errors import ConfigError, DatasetError
from openral_data.formats.episodic import ArrayEpisode, ArraySource, ArraySpec
from openral_data.formats.lerobot_v3.encoder import Codec, VideoSettings
from openral_data.formats.staging import Staging, check_new_output
from openral_data.schemas.mapping import Mapping

CHUNK_BYTES = 64 * 1024 * 1024  # decoded rows read at once, over all mapped arrays of an episode
MAX_CHUNK_ROWS = 1024
ProgressFn = Callable[[int, int], None]  # (steps read, steps in total)


class _Picture:
    """A decoded picture in the shape the Converter's decoder threads take (`decode()`)."""

    __slots__ = ("img",)

    def __init__(self, img: npt.NDArray[np.uint8]) -> None:
        self.img = img

    def decode(self) -> npt.NDArray[np.uint8]:
        return self.img


def check_array_mapping(mapping: Mapping, where: str) -> None:
    """What a bag mapping may say that an array source cannot take."""
    for key, value in (("depth_cameras", mapping.depth_cameras), ("camera_info", mapping.camera_info)):
        if value:
            raise ConfigError(f"{where}: {key}: not supported for array sources (map colour cameras only)")
    if mapping.success is not None and mapping.success.marker:
        raise ConfigError(f"{where}: success.marker: array sources have no episode markers (use success.topic)")
    if mapping.columns:
        raise ConfigError(f"{where}: columns: bags only (array sources map state, action, cameras, reward, success)")


def named(mapping: Mapping, first: ArrayEpisode, where: str) -> Mapping:
    """`mapping` with every vector part that has no names named `<key>[i]` (widths from the first episode)."""
    specs = {s.key: s for s in first.specs()}
    data = mapping.model_dump(mode="json", exclude_none=True)
    for role, vector in mapping.vectors():
        parts = data[role]["parts"] if vector.parts is not None else [data[role]]
        for part, source in zip(parts, vector.sources(), strict=True):
            if source.fixed_names() is None:
                spec = _spec(specs, source.topic, f"{where}: {first.name}", role, first.meta.ignored)
                width = int(np.prod(spec.shape)) if spec.shape else 1
                part["names"] = [f"{source.topic}[{i}]" for i in range(width)]
    return Mapping.model_validate(data)


def _spec(
    specs: dict[str, ArraySpec], key: str, where: str, role: str, ignored: dict[str, str] | None = None
) -> ArraySpec:
    spec = specs.get(key)
    if spec is None and ignored and key in ignored:
        raise DatasetError(f"{where}/{key}: {role}: not a per-step array: {ignored[key]}", code="dataset.source.shape")
    if spec is None:
        raise DatasetError(f"{where}/{key}: missing ({role}; per-step arrays: {', '.join(specs) or '-'})",
                           code="dataset.source.key")  # fmt: skip
    return spec


def check_episode(ep: ArrayEpisode, mapping: Mapping, where: str) -> dict[str, ArraySpec]:
    """Every mapped key of `ep` present and of its role's kind; returns the mapped keys' specs."""
    specs = {s.key: s for s in ep.specs()}
    ignored = ep.meta.ignored
    at = f"{where}: {ep.name}"
    out: dict[str, ArraySpec] = {}
    for role, source in mapping.vector_sources():
        spec = out[source.topic] = _spec(specs, source.topic, at, role, ignored)
        width = int(np.prod(spec.shape)) if spec.shape else 1
        names = source.fixed_names()
        if not is_vector(spec) and len(spec.shape) > 1:
            raise DatasetError(f"{at}/{source.topic}: {role}: shape {spec.shape} a step, not a vector",
                               code="dataset.source.shape")  # fmt: skip
        if names is not None and len(names) != width:
            raise DatasetError(f"{at}/{source.topic}: {role}: {width} values a step, the mapping names {len(names)}",
                               code="dataset.source.shape")  # fmt: skip
    for name, key in mapping.cameras.items():
        spec = out[key] = _spec(specs, key, at, f"cameras.{name}", ignored)
        if not is_picture(spec):
            raise DatasetError(f"{at}/{key}: cameras.{name}: {spec.dtype} {spec.shape} a step, not an HxWx3 uint8 "
                               "picture", code="dataset.source.dtype")  # fmt: skip
    for what, scalar in (("reward", _topic(mapping.reward)), ("success", mapping.success_topic)):
        if scalar is not None:
            spec = out[scalar] = _spec(specs, scalar, at, what, ignored)
            if spec.encoding != "raw" or int(np.prod(spec.shape)) != 1:
                raise DatasetError(f"{at}/{scalar}: {what}: shape {spec.shape} a step, not one number",
                                   code="dataset.source.shape")  # fmt: skip
    if mapping.task_topic == LANGUAGE and not ep.meta.language:
        raise DatasetError(f"{at}: task_topic {LANGUAGE}: the episode has no language instruction",
                           code="dataset.source.key")  # fmt: skip
    if mapping.task_topic is not None and mapping.task_topic != LANGUAGE:
        raise ConfigError(f"{where}: task_topic: array sources take task (a text) or task_topic: {LANGUAGE}")
    return out


def _topic(source: Any) -> str | None:
    return source.topic if source is not None else None


def _finite(rows: npt.NDArray[Any], at: str, start: int) -> npt.NDArray[np.float64]:
    values = np.asarray(rows, dtype=np.float64)
    bad = ~np.isfinite(values.reshape(len(values), -1)).all(axis=1)
    if bad.any():
        raise DatasetError(f"{at}: non-finite value at step {start + int(np.flatnonzero(bad)[0])}",
                           code="dataset.source.value")  # fmt: skip
    return values


def convert_arrays(
    source: ArraySource,
    dst: Path,
    mapping: Mapping,
    *,
    codec: Codec = "av1",
    progress: ProgressFn | None = None,
    checks: bool = True,
    total: int | None = None,
    video: VideoSettings | None = None,
) -> ConvertSummary:
    """Convert every episode of `source` into a new LeRobot v3 dataset at `dst` (staged: DST appears complete
    or not at all). `checks=False` (a block of `convert --workers`): a block without an episode publishes
    nothing. `total`: the steps of the whole source, for progress (None: counted here first)."""
    where = str(source.path)
    check_array_mapping(mapping, where)
    summary = ConvertSummary(src=source.path, dst=dst, bags=len(getattr(source, "files", [source.path])))
    summary.source_kind = source.layout
    total = sum(ep.length for ep in source.episodes()) if total is None else total
    check_new_output(dst, "DST")
    staged = Staging(dst, "openral-data convert")
    with staged as staging:
        conv = Converter(mapping, staging, VideoSettings.given(codec, video=video), summary, CameraTopics())
        t0 = time.perf_counter()
        done = 0
        try:
            for ep in source.episodes():
                done = _episode(conv, ep, where, done, total, progress)
            if progress is not None:
                progress(total, total)
        finally:
            conv.close()
            source.close()
        summary.seconds = time.perf_counter() - t0
        if not checks and not summary.episodes:
            return summary
        if checks:
            check_outcome(summary)
        staged.publish("DST")
    return summary


def _episode(conv: Converter, ep: ArrayEpisode, where: str, done: int, total: int, progress: ProgressFn | None) -> int:
    """One source episode through the Converter, chunk by chunk; returns the steps read so far."""
    mapping = conv.mapping
    specs = check_episode(ep, mapping, where)
    for key, spec in specs.items():
        conv.summary.topics.setdefault(key, TopicReport(key, f"{spec.dtype}{list(spec.shape)} ({spec.encoding})"))
    split = {"split": ep.meta.split, "source_name": ep.name} if ep.meta.split else {}  # info.json's splits
    conv.start_source_episode((mapping.task_topic and ep.meta.language) or mapping.task or "", split)
    step_bytes = sum(max(1, int(np.prod(s.shape))) * np.dtype(s.dtype).itemsize for s in specs.values())
    rows = max(1, min(MAX_CHUNK_ROWS, CHUNK_BYTES // max(1, step_bytes)))
    period = 1e9 / mapping.fps
    parts = {(s.topic, s.offset) for _role, s in mapping.vector_sources()}
    for start in range(0, ep.length, rows):
        stop = min(ep.length, start + rows)
        chunk = {key: ep.read(key, start, stop) for key in specs}
        vectors = {(key, k): _vector_rows(ep, key, k, chunk[key], start, stop, where) for key, k in parts}
        _take_chunk(conv, ep, chunk, vectors, start, stop, period, where)
        done += stop - start
        if progress is not None:
            progress(done, total)
    for key in specs:
        rep = conv.summary.topics[key]
        rep.messages += ep.length
        rep.used += ep.length
    conv.end_source_episode(None)
    return done


def _vector_rows(
    ep: ArrayEpisode, key: str, offset: int, rows: npt.NDArray[Any], start: int, stop: int, where: str
) -> npt.NDArray[np.float32]:
    """Steps start..stop of a vector part as float32, checked finite: `rows` (those steps of `key`) for offset 0,
    else steps start + offset .. stop + offset read here, the episode's last step standing for those past it."""
    at = f"{where}: {ep.name}/{key}"
    if offset == 0:
        return _finite(rows, at, start).astype(np.float32)
    steps = np.minimum(np.arange(start + offset, stop + offset), ep.length - 1)
    first = int(steps[0])
    read = _finite(ep.read(key, first, int(steps[-1]) + 1), at, first)
    shifted: npt.NDArray[np.float32] = read[steps - first].astype(np.float32)
    return shifted


def _take_chunk(
    conv: Converter, ep: ArrayEpisode, chunk: dict[str, npt.NDArray[Any]],
    vectors: dict[tuple[str, int], npt.NDArray[np.float32]], start: int, stop: int, period: float, where: str,
) -> None:  # fmt: skip
    mapping = conv.mapping
    at = f"{where}: {ep.name}"
    values: dict[str, npt.NDArray[Any]] = {}
    streams: list[tuple[str, tuple[str, int]]] = []  # (stream, (key, offset)) of the vector parts
    for _role, keys in conv.vector_streams.items():
        for stream in keys:
            source = conv.readers[stream].source
            streams.append((stream, (source.topic, source.offset)))
    reward = _topic(mapping.reward)
    if reward is not None:
        values[reward] = _finite(chunk[reward], f"{at}/{reward}", start).reshape(-1)
    success = mapping.success_topic
    done_flags = _finite(chunk[success], f"{at}/{success}", start).reshape(-1) != 0 if success else None
    for i in range(stop - start):
        t = round((start + i) * period)
        samples: dict[str, Any] = {stream: vectors[part][i].reshape(-1) for stream, part in streams}
        for name, key in mapping.cameras.items():
            samples[name] = _Picture(chunk[key][i])
        if reward is not None:
            samples[REWARD] = float(values[reward][i])
        if done_flags is not None:
            conv.note_success(t, bool(done_flags[i]))
        conv.take(AlignedFrame(start + i, t, samples))
