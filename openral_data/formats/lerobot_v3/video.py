"""Streaming video encoding with PyAV: one encoder thread per camera behind a bounded queue of frames.

Frames go straight from the producer to the encoder (no PNG staging). When the queue is full the producer either
waits (backpressure: converting, editing, a simulation) or, with `spill` (a real-time recording, whose loop must
never wait), hands the frame to the camera's spill thread (spill.py), which writes it raw (`.npy`) into the
staging folder beside the episode's mp4, and queues its place: the encoder takes it from memory or reads it back
in turn and deletes it, so frames are never dropped, stay in order, no file is written on the producer's thread,
and memory stays bounded (`queue_size` frames per camera for the encoder, as many for the spill thread). A killed
recorder's spilled frames are staged files (`.NAME.tmp`) of an unfinished episode: recovery (`record --resume`,
`doctor --repair`) moves them to the quarantine.

Test hook: the environment variable `OPENRAL_TEST_ENCODE_DELAY_S` (seconds, read when an episode begins) makes the
encoder thread sleep that long before each frame, so tests can throttle a real encoder and watch it spill.

Each episode is encoded into its own complete mp4 (so a finished episode is durable the moment its encoder is
flushed); `concat_mp4` later joins a group of such files into one without re-encoding.
"""

from __future__ import annotations

import contextlib
import os
import queue
import sys
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
from openral_data.formats.lerobot_v3.depth import CameraStats, DepthStatsAccumulator, DepthStream
from openral_data.formats.lerobot_v3.encoder import VideoSettings
from openral_data.formats.lerobot_v3.spill import SpillBudget, Spilled, SpillWriter
from openral_data.formats.lerobot_v3.stats import ImageStatsAccumulator
from openral_data.paths import regular_file


@dataclass
class EncodedEpisode:
    path: Path
    frames: int
    stats: CameraStats


ENCODE_DELAY_ENV = "OPENRAL_TEST_ENCODE_DELAY_S"  # the test hook (module docstring)
# a real-time recording's encoder threads run this much nicer than the process (`yield_to_the_loop`): the nicest
# (19) measured 118-160 loop overruns in 600 ticks against 233-237 at the process's own priority (bench_capture.py,
# 3 cameras h264, interleaved; benchmarks/README.md)
ENCODER_NICE = 19
CAPTURE = "capture"  # openral.episode_info's key of a spilling recording's per-camera `EncoderLag`


@dataclass
class EncoderLag:
    """One camera's episode, as its encoder kept up: frames spilled to disk, and the longest a frame waited
    between being handed over and being encoded (seconds)."""

    spilled: int = 0
    max_lag: float = 0.0

    def to_json(self) -> dict[str, float | int]:
        return {"spilled": self.spilled, "encoder_lag_s": round(self.max_lag, 4)}


@dataclass
class EncodeJob:
    path: Path
    height: int
    width: int
    done: threading.Event = field(default_factory=threading.Event)
    result: EncodedEpisode | None = None
    error: BaseException | None = None
    lag: EncoderLag = field(default_factory=EncoderLag)

    @property
    def spill_dir(self) -> Path:
        return self.path.with_name(self.path.name + ".spill")


class _RgbInput:
    """A job's rgb24 input frame, refilled for each image by one numpy copy (PyAV's `from_ndarray` copies twice,
    holding the GIL). `encode` converts it to the encoder's pixel format before it returns, so the next image may
    overwrite it; an encoder fed rgb24 itself gets a new frame each time."""

    def __init__(self, height: int, width: int, pix_fmt: str) -> None:
        self._reuse = pix_fmt != "rgb24"
        self._size = (height, width)
        self._frame, self._pixels = self._new()

    def _new(self) -> tuple[av.VideoFrame, npt.NDArray[np.uint8]]:
        height, width = self._size
        frame = av.VideoFrame(width, height, "rgb24")
        plane = frame.planes[0]
        return frame, np.frombuffer(plane, np.uint8).reshape(height, plane.line_size)[:, : width * 3]

    def fill(self, image: npt.NDArray[Any]) -> av.VideoFrame:
        frame, pixels = (self._frame, self._pixels) if self._reuse else self._new()
        pixels[...] = image.reshape(pixels.shape)
        return frame


# Control markers on a worker's queue, besides jobs and frames.
_FINISH = object()  # end of the episode: flush the encoder, close the file
_ABORT = object()  # drop the episode: close the file, the producer deletes it
_STOP = object()  # shut the thread down (ends a job in progress as an abort)


def _ends_job(item: object) -> bool:
    """Whether a queue item is a marker that ends the job in progress (a frame does not)."""
    return item is _FINISH or item is _ABORT or item is _STOP


class EncoderWorker:
    """A persistent thread encoding one camera. At most `queue_size` frames wait in memory; beyond that `put`
    waits for the encoder (backpressure), or with `spill` (the spilled bytes' budget) hands the frame to the spill
    thread and returns at once (module docstring): nothing is dropped either way. A job (one episode's mp4) ends
    only through `finish()` or `abort()`. With `depth`, frames are depth maps, quantized and encoded as lerobot's
    depth videos (`depth.py`) instead of RGB with `settings`."""

    def __init__(
        self,
        name: str,
        settings: VideoSettings,
        fps: int,
        queue_size: int = 16,
        depth: DepthStream | None = None,
        threads: int | None = None,
        spill: SpillBudget | None = None,
    ) -> None:
        self.name = name
        self.settings = settings
        self.threads = threads  # this encoder's thread budget (SVT-AV1 lp, x264 threads); None: settings.threads
        self.depth = depth
        self.fps = fps
        self.spill = None if spill is None else SpillWriter(name, spill, queue_size)
        # frames, spilled frames' paths, jobs and markers (a SimpleQueue: C put/get, a few µs less per frame)
        self._q: queue.SimpleQueue[object] = queue.SimpleQueue()
        self._slots = threading.Semaphore(max(1, queue_size))  # one per frame held in memory
        self._job: EncodeJob | None = None
        self._failed: BaseException | None = None
        self.waited = 0.0  # this episode: seconds `put` waited on a full queue (the encoder was behind) ...
        self.waits = 0  # ... and how many frames had to wait
        self.lag = EncoderLag()  # the last finished episode's spills and encoder lag
        self._thread = threading.Thread(target=self._run, name=f"encoder-{name}", daemon=True)
        self._thread.start()

    # -- producer side -------------------------------------------------------------------------------
    def begin(self, path: Path, height: int, width: int) -> None:
        self._raise_if_failed()
        if self._job is not None:
            raise EncoderError(f"{self.name}: begin() while an episode is being encoded")
        self._job = EncodeJob(path, height, width)
        self.waited, self.waits = 0.0, 0
        self._q.put(self._job)

    def put(self, frame: npt.NDArray[Any]) -> None:
        """Queue a frame. While `queue_size` frames are waiting: spill it to disk (`spill`), else wait (counted
        in `waited` seconds and `waits` frames)."""
        self._raise_if_failed()
        job = self._job
        if job is None:
            raise EncoderError(f"{self.name}: put() without begin()")
        now = time.perf_counter()
        if self._slots.acquire(blocking=False):
            self._q.put((frame, now))
        elif self.spill is not None:
            self._spill(job, self.spill, frame, now)
        else:
            self._slots.acquire()
            self.waited += time.perf_counter() - now
            self.waits += 1
            self._q.put((frame, now))

    def _spill(self, job: EncodeJob, spill: SpillWriter, frame: npt.NDArray[Any], now: float) -> None:
        """Hand `frame` to the spill thread; with its queue full too, wait (counted) for a place in either queue."""
        if not spill.reserve():
            while not spill.reserve(timeout=0.002):
                self._raise_if_failed()
                if self._slots.acquire(blocking=False):  # the encoder caught up first
                    self.waited += time.perf_counter() - now
                    self.waits += 1
                    self._q.put((frame, now))
                    return
            self.waited += time.perf_counter() - now
            self.waits += 1
        item = spill.submit(job.spill_dir / f".{job.lag.spilled:06d}.npy.tmp", frame)
        job.lag.spilled += 1
        self._q.put((item, now))

    def finish(self) -> EncodedEpisode:
        return self.wait(self.finish_later())

    def finish_later(self) -> EncodeJob:
        """End the episode without waiting for its encoder: the next episode may `begin` at once (its frames queue
        behind this one's); `wait(job)` then returns this episode's mp4."""
        job = self._job
        if job is None:
            raise EncoderError(f"{self.name}: finish() without begin()")
        self._q.put(_FINISH)
        self._job = None
        return job

    def wait(self, job: EncodeJob) -> EncodedEpisode:
        """The episode `finish_later` ended, once its encoder has flushed it (its spilled frames read back)."""
        job.done.wait()
        self.lag = job.lag
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
        if self.spill is not None:
            self.spill.close()

    def _raise_if_failed(self) -> None:
        if self.spill is not None and self.spill.error is not None:
            raise self.spill.error
        if self._failed is not None:
            raise EncoderError(f"encoder {self.name} failed: {self._failed}") from self._failed

    # -- encoder thread ------------------------------------------------------------------------------
    def _run(self) -> None:
        if self.spill is not None:
            yield_to_the_loop()
        while True:
            item = self._q.get()
            if item is _STOP:
                return
            if isinstance(item, EncodeJob) and self._encode_job(item) is _STOP:
                return
            # stray _FINISH/_ABORT markers (from an abort racing a finish) are ignored while idle

    def _next(self, job: EncodeJob) -> npt.NDArray[Any] | object:
        """The job's next frame (a spilled one read back and deleted; its lag counted), or the marker ending it."""
        item = self._q.get()
        if _ends_job(item):
            return item
        assert isinstance(item, tuple)
        frame, handed = item
        if isinstance(frame, Spilled):
            assert self.spill is not None
            image: npt.NDArray[Any] = self.spill.claim(frame)
        else:
            self._slots.release()
            image = frame
        job.lag.max_lag = max(job.lag.max_lag, time.perf_counter() - handed)
        return image

    def _encode_job(self, job: EncodeJob) -> object:
        """Encode frames until a marker ends the job; return that marker."""
        depth = self.depth
        stats = ImageStatsAccumulator() if depth is None else DepthStatsAccumulator(depth.unit)
        encoder, options, pix_fmt = (
            (self.settings.encoder, self.settings.options(self.threads, job.width), self.settings.encoder_pix_fmt)
            if depth is None
            else (depth.settings.encoder, depth.settings.options(), depth.settings.pix_fmt)
        )
        delay = float(os.environ.get(ENCODE_DELAY_ENV, "0") or 0)
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
            frame_of = depth.frame if depth is not None else _RgbInput(job.height, job.width, pix_fmt).fill
            while not _ends_job(item := self._next(job)):
                assert isinstance(item, np.ndarray)
                if delay > 0:
                    time.sleep(delay)
                vf = frame_of(item)  # reads the whole frame: the histogram's sampled rows are then in cache
                stats.add(item)
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
                if _ends_job(item := self._next(job)):
                    end = item
        finally:
            if container is not None:
                with contextlib.suppress(Exception):
                    container.close()
            with contextlib.suppress(OSError):
                job.spill_dir.rmdir()  # empty once every spilled frame was read back
            job.done.set()
        return end


def yield_to_the_loop() -> None:
    """Make this thread ENCODER_NICE nicer than it is (Linux, where a thread has its own nice value and the threads
    it starts inherit it: the codec's own, x264's and SVT-AV1's, started when its first frame opens the codec).

    A real-time recording's encoders are the one load that may fall behind (their frames spill to disk and are
    encoded later, nothing lost); the control loop and the cameras' capture threads may not. When the cores are
    short, the scheduler then runs those first instead of sharing the cores out evenly among every thread."""
    if sys.platform != "linux":
        return
    tid = threading.get_native_id()
    with contextlib.suppress(OSError):
        os.setpriority(os.PRIO_PROCESS, tid, min(19, os.getpriority(os.PRIO_PROCESS, tid) + ENCODER_NICE))


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
