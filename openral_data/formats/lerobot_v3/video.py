"""Streaming video encoding with PyAV: one encoder thread per camera, a bounded queue for backpressure.

Frames go straight from the producer to the encoder (no PNG staging). Each episode is encoded into its own
complete mp4 (so a finished episode is durable the moment its encoder is flushed); `concat_mp4` later joins
a group of such files into one without re-encoding.
"""

from __future__ import annotations

import contextlib
import os
import queue
import threading
import time
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import Any

import av

# SVT-AV1 prints its configuration banner to stderr on every encoder unless told otherwise (1 = errors only).
os.environ.setdefault("SVT_LOG", "1")
import numpy as np
import numpy.typing as npt

from openral_data.errors import EncoderError
from openral_data.formats.codec import Codec
from openral_data.formats.lerobot_v3.depth import CameraStats, DepthStatsAccumulator, DepthStream
from openral_data.formats.lerobot_v3.stats import ImageStatsAccumulator
from openral_data.paths import regular_file


@dataclass(frozen=True)
class VideoSettings:
    """lerobot 0.6.1's encoder defaults: yuv420p, g=2, crf=30; SVT-AV1 preset 12, fast-decode 0."""

    codec: Codec = "av1"
    crf: int = 30
    g: int = 2
    preset: int | None = None
    pix_fmt: str = "yuv420p"

    @property
    def encoder(self) -> str:
        return {"av1": "libsvtav1", "h264": "libx264"}[self.codec]

    @property
    def effective_preset(self) -> int | str | None:
        if self.codec == "av1":
            return 12 if self.preset is None else self.preset
        return self.preset

    def size_problem(self, height: int, width: int) -> str | None:
        """Why frames of this size cannot be encoded, or None. (SVT-AV1 dies with SIGFPE below ~26 px wide.)"""
        if height % 2 or width % 2:
            return f"{width}x{height}: video (yuv420p) needs even width and height"
        low = 32 if self.codec == "av1" else 16
        if height < low or width < low:
            return f"{width}x{height}: {self.codec} video needs at least {low}x{low} pixels"
        return None

    def options(self) -> dict[str, str]:
        opts = {"g": str(self.g), "crf": str(self.crf)}
        if self.effective_preset is not None:
            opts["preset"] = str(self.effective_preset)
        if self.codec == "av1":
            opts["svtav1-params"] = "fast-decode=0"
        return opts

    def feature_info(self, height: int, width: int, fps: int) -> dict[str, Any]:
        """The `info` block lerobot writes for a video feature."""
        return {
            "video.height": height,
            "video.width": width,
            "video.codec": self.codec,
            "video.pix_fmt": self.pix_fmt,
            "video.fps": fps,
            "video.channels": 3,
            "has_audio": False,
            "video.g": self.g,
            "video.crf": self.crf,
            "video.preset": self.effective_preset,
            "video.fast_decode": 0,
            "video.video_backend": "pyav",
            "video.extra_options": {},
            "is_depth_map": False,
        }


@dataclass
class EncodedEpisode:
    path: Path
    frames: int
    stats: CameraStats


@dataclass
class _Job:
    path: Path
    height: int
    width: int
    done: threading.Event = field(default_factory=threading.Event)
    result: EncodedEpisode | None = None
    error: BaseException | None = None


# Control markers on a worker's queue, besides jobs and frames.
_FINISH = object()  # end of the episode: flush the encoder, close the file
_ABORT = object()  # drop the episode: close the file, the producer deletes it
_STOP = object()  # shut the thread down (ends a job in progress as an abort)


def _ends_job(item: object) -> bool:
    """Whether a queue item is a marker that ends the job in progress (a frame does not)."""
    return item is _FINISH or item is _ABORT or item is _STOP


class EncoderWorker:
    """A persistent thread encoding one camera. `put` blocks while the queue is full: the producer waits,
    nothing is dropped. A job (one episode's mp4) ends only through `finish()` or `abort()`. With `depth`, frames
    are depth maps, quantized and encoded as lerobot's depth videos (`depth.py`) instead of RGB with `settings`."""

    def __init__(
        self, name: str, settings: VideoSettings, fps: int, queue_size: int = 16, depth: DepthStream | None = None
    ) -> None:
        self.name = name
        self.settings = settings
        self.depth = depth
        self.fps = fps
        self._q: queue.Queue[object] = queue.Queue(maxsize=queue_size)
        self._job: _Job | None = None
        self._failed: BaseException | None = None
        self.waited = 0.0  # this episode: seconds `put` waited on a full queue (the encoder was behind) ...
        self.waits = 0  # ... and how many frames had to wait
        self._thread = threading.Thread(target=self._run, name=f"encoder-{name}", daemon=True)
        self._thread.start()

    # -- producer side -------------------------------------------------------------------------------
    def begin(self, path: Path, height: int, width: int) -> None:
        self._raise_if_failed()
        if self._job is not None:
            raise EncoderError(f"{self.name}: begin() while an episode is being encoded")
        self._job = _Job(path, height, width)
        self.waited, self.waits = 0.0, 0
        self._q.put(self._job)

    def put(self, frame: npt.NDArray[Any]) -> None:
        """Queue a frame; while the queue is full, wait (counted in `waited` seconds and `waits` frames)."""
        self._raise_if_failed()
        try:
            self._q.put_nowait(frame)
        except queue.Full:
            t0 = time.perf_counter()
            self._q.put(frame)
            self.waited += time.perf_counter() - t0
            self.waits += 1

    def finish(self) -> EncodedEpisode:
        job = self._job
        if job is None:
            raise EncoderError(f"{self.name}: finish() without begin()")
        self._q.put(_FINISH)
        job.done.wait()
        self._job = None
        if job.error is not None:
            job.path.unlink(missing_ok=True)
            raise EncoderError(f"encoding {job.path} failed: {job.error}") from job.error
        assert job.result is not None
        return job.result

    def abort(self) -> None:
        """Drop the current episode: stop encoding it and delete its file."""
        job = self._job
        if job is None:
            return
        if not job.done.is_set():
            self._q.put(_ABORT)  # if a _FINISH got there first, the idle thread ignores this marker
            job.done.wait()
        self._job = None
        job.path.unlink(missing_ok=True)

    def close(self) -> None:
        self.abort()
        self._q.put(_STOP)
        self._thread.join()

    def _raise_if_failed(self) -> None:
        if self._failed is not None:
            raise EncoderError(f"encoder {self.name} failed: {self._failed}") from self._failed

    # -- encoder thread ------------------------------------------------------------------------------
    def _run(self) -> None:
        while True:
            item = self._q.get()
            if item is _STOP:
                return
            if isinstance(item, _Job) and self._encode_job(item) is _STOP:
                return
            # stray _FINISH/_ABORT markers (from an abort racing a finish) are ignored while idle

    def _encode_job(self, job: _Job) -> object:
        """Encode frames until a marker ends the job; return that marker."""
        depth = self.depth
        stats = ImageStatsAccumulator() if depth is None else DepthStatsAccumulator(depth.unit)
        encoder, options, pix_fmt = (
            (self.settings.encoder, self.settings.options(), self.settings.pix_fmt)
            if depth is None
            else (depth.settings.encoder, depth.settings.options(), depth.settings.pix_fmt)
        )
        frames = 0
        container = None
        end: object | None = None  # the marker that ended this job, once it has arrived
        try:
            job.path.parent.mkdir(parents=True, exist_ok=True)
            container = av.open(str(job.path), mode="w", format="mp4")
            stream: av.VideoStream = container.add_stream(  # type: ignore[assignment]
                encoder, rate=self.fps, options=options
            )
            stream.width = job.width
            stream.height = job.height
            stream.pix_fmt = pix_fmt
            stream.codec_context.time_base = Fraction(1, self.fps)
            while not _ends_job(item := self._q.get()):
                assert isinstance(item, np.ndarray)
                stats.add(item)
                vf = av.VideoFrame.from_ndarray(item, format="rgb24") if depth is None else depth.frame(item)
                vf.pts = frames
                frames += 1
                for packet in stream.encode(vf):
                    container.mux(packet)
            end = item
            # always drain the encoder (SVT-AV1 complains when torn down without end-of-stream); an aborted
            # file is deleted by the producer afterwards
            for packet in stream.encode(None):
                container.mux(packet)
            container.close()
            container = None
            job.result = EncodedEpisode(job.path, frames, stats)
        except BaseException as exc:  # noqa: BLE001 - reported to the producer thread
            job.error = exc
            self._failed = exc
            # consume this job's frames up to its end marker so the producer is never blocked forever
            while end is None:
                if _ends_job(item := self._q.get()):
                    end = item
        finally:
            if container is not None:
                with contextlib.suppress(Exception):
                    container.close()
            job.done.set()
        return end


def probe_frames(path: Path) -> int:
    container = av.open(str(regular_file(path)))
    try:
        return sum(1 for p in container.demux(container.streams.video[0]) if p.size)
    finally:
        container.close()


def concat_mp4(sources: list[tuple[Path, int]], dest: Path, fps: int) -> None:
    """Concatenate complete per-episode mp4s (path, n_frames) into `dest` without re-encoding.

    Episode k starts at exactly (frames of episodes before it) / fps; pts are shifted by whole frames. Only each
    source's first `n_frames` packets are taken: a group's first file may already hold the join of a previous
    attempt that a disk error or a kill cut short before the metadata named it (its own episode comes first).
    """
    out = av.open(str(dest), mode="w", format="mp4", options={"movflags": "faststart"})
    try:
        out_stream = None
        offset_frames = 0
        for src, n_frames in sources:
            with av.open(str(src)) as inp:
                in_stream = inp.streams.video[0]
                if out_stream is None:
                    out_stream = out.add_stream_from_template(in_stream, opaque=True)
                tb = in_stream.time_base
                assert tb is not None
                per_frame = Fraction(1, fps) / tb
                if per_frame.denominator != 1:
                    raise EncoderError(f"{src}: time base {tb} cannot express frame boundaries at {fps} fps")
                shift = int(per_frame) * offset_frames
                taken = 0
                for packet in inp.demux(in_stream):
                    if packet.dts is None:
                        continue
                    if taken == n_frames:  # a first file already joined once (a join cut short) holds more
                        break
                    taken += 1
                    assert packet.pts is not None
                    packet.pts += shift
                    packet.dts += shift
                    packet.stream = out_stream
                    out.mux(packet)
            offset_frames += n_frames
    finally:
        out.close()


def count_packets(path: Path) -> list[float]:
    """Presentation times (s) of every video packet of the file's first video stream, without decoding."""
    container = av.open(str(regular_file(path)))
    try:
        stream = container.streams.video[0]
        tb = stream.time_base
        if tb is None:
            raise ValueError("video stream without time base")
        return sorted(float(p.pts * tb) for p in container.demux(stream) if p.pts is not None and p.size)
    finally:
        container.close()
