"""The MCAP sink: one rosbag2 bag (``metadata.yaml`` + ``.mcap``, CDR) per episode, written with rosbags.

Layout under ``root``::

    episode_000000/{metadata.yaml, episode_000000.mcap}
    episode_000001/...
    .partial/episode_000002/...        <- the episode in flight (never read by `convert`)

An episode is written into ``.partial/`` and renamed to ``episode_NNNNNN`` only after rosbags closed the bag
(summary + metadata.yaml) and both files were fsynced; a killed recording therefore leaves every finished
episode complete and the unfinished one out of sight.

Frames reach a writer thread through a bounded queue: a full queue blocks the producer (backpressure), so a
frame cannot be dropped. Each camera image is handed to a small encoder pool as the frame is queued (Pillow
releases the GIL while encoding, so JPEG/PNG of several cameras and frames run in parallel with the producer);
the writer thread takes the frames in order, waits for their images, serialises CDR and writes.

Stamps: ``episode start wall clock (ns since the epoch, taken at begin_episode) + Frame.timestamp``. The
relative times are the producer's clock (sim time for sim, a monotonic clock for hardware), the absolute
base puts the bag at the moment it was recorded so tools show real dates and episodes never overlap.
"""

from __future__ import annotations

import contextlib
import os
import queue
import shutil
import threading
import time
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final, Literal

from rosbags.interfaces import Connection
from rosbags.rosbag2 import StoragePlugin, Writer

from openral_data.errors import OpenralError
from openral_data.sinks.base import DatasetSchema, EpisodeRecord, EpisodeStart, Frame
from openral_data.sinks.lerobot_v3.atomic import fsync_dir, fsync_file
from openral_data.sinks.mcap import messages as m
from openral_data.sinks.mcap.messages import ImageFormat, MessageFactory

PARTIAL = ".partial"
ROSBAG2_VERSION: Final[Literal[8]] = 8  # Humble/Iron readers accept 8; Jazzy reads 8 and 9


def episode_dir(root: Path, index: int) -> Path:
    return root / f"episode_{index:06d}"


def finished_bags(root: Path) -> list[Path]:
    """The complete episode bags under `root`, in episode order."""
    return sorted(p for p in root.glob("episode_*") if (p / "metadata.yaml").is_file())


@dataclass(frozen=True)
class McapConfig:
    image_format: ImageFormat = "jpeg"
    jpeg_quality: int = 90
    queue_size: int = 16
    durable: bool = True


@dataclass
class _Begin:
    index: int
    start: EpisodeStart
    base_ns: int


@dataclass
class _Queued:
    frame: Frame
    encoded: dict[str, Future[bytes]]  # camera -> its JPEG/PNG being encoded in the pool (empty for raw)


@dataclass
class _End:
    success: bool


_ABORT = object()
_STOP = object()


class McapSink:
    """A `Sink` writing one rosbag2/MCAP bag per episode under `root`."""

    def __init__(self, root: Path, schema: DatasetSchema, config: McapConfig | None = None) -> None:
        self.root = root
        self.schema = schema
        self.config = config or McapConfig()
        if self.config.image_format not in m.IMAGE_FORMATS:
            raise OpenralError(f"image format {self.config.image_format!r}: expected one of {m.IMAGE_FORMATS}")
        if root.exists() and (not root.is_dir() or any(p.name != PARTIAL for p in root.iterdir())):
            raise OpenralError(f"{root}: output exists and is not empty; refusing to overwrite it")
        self._created_root = not root.exists()
        root.mkdir(parents=True, exist_ok=True)
        self.episodes = 0
        self.next_index: int | None = None  # names the next episode's bag; default: episodes written so far
        self._open = False
        self._closed = False
        self._queue: queue.Queue[object] = queue.Queue(maxsize=self.config.queue_size)
        self._results: queue.Queue[EpisodeRecord | BaseException | None] = queue.Queue()
        self._error: BaseException | None = None
        self._factory = MessageFactory(self.config.image_format, self.config.jpeg_quality)
        workers = min(len(schema.cameras), os.cpu_count() or 1, 4)
        self._pool = (
            ThreadPoolExecutor(workers, thread_name_prefix="mcap-image")
            if workers and self.config.image_format != "raw"
            else None
        )
        self._thread = threading.Thread(target=self._run, name="mcap-writer", daemon=True)
        self._thread.start()

    # -- Sink API (producer thread) --------------------------------------------------------------------------
    def begin_episode(self, start: EpisodeStart) -> None:
        if self._open:
            raise RuntimeError("begin_episode() while an episode is open")
        self._raise_if_failed()
        index = self.episodes if self.next_index is None else self.next_index
        self.next_index = None
        if episode_dir(self.root, index).exists():
            raise OpenralError(f"{episode_dir(self.root, index)}: exists; refusing to overwrite it")
        self._open = True
        self._put(_Begin(index, start, time.time_ns()))

    def add_frame(self, frame: Frame) -> None:
        if not self._open:
            raise RuntimeError("add_frame() outside an episode")
        encoded: dict[str, Future[bytes]] = {}
        if self._pool is not None:
            for name, img in frame.images.items():
                encoded[name] = self._pool.submit(self._factory.compress, img)
        self._put(_Queued(frame, encoded))  # blocks while the writer is behind: backpressure, never a drop

    def end_episode(self, success: bool) -> EpisodeRecord:
        if not self._open:
            raise RuntimeError("end_episode() outside an episode")
        self._open = False
        self._put(_End(success))
        result = self._wait_result()
        if isinstance(result, BaseException):
            raise result
        assert result is not None
        self.episodes += 1
        return result

    def discard_episode(self) -> None:
        if not self._open:
            return
        self._open = False
        self._put(_ABORT)
        self._wait_result()

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        self.discard_episode()
        if self._thread.is_alive():
            self._queue.put(_STOP)
            self._thread.join()
        if self._pool is not None:
            self._pool.shutdown(wait=True)
        shutil.rmtree(self.root / PARTIAL, ignore_errors=True)
        if self.episodes == 0 and self._created_root:
            shutil.rmtree(self.root, ignore_errors=True)

    def _put(self, item: object) -> None:
        while True:
            self._raise_if_failed()
            try:
                self._queue.put(item, timeout=0.5)
                return
            except queue.Full:
                continue

    def _wait_result(self) -> EpisodeRecord | BaseException | None:
        while True:
            try:
                return self._results.get(timeout=0.5)
            except queue.Empty:
                self._raise_if_failed()

    def _raise_if_failed(self) -> None:
        if self._error is not None and not self._thread.is_alive():
            raise OpenralError(f"MCAP writer failed: {self._error}") from self._error

    # -- writer thread ---------------------------------------------------------------------------------------
    def _run(self) -> None:
        episode: _EpisodeBag | None = None
        failed: BaseException | None = None
        try:
            while True:
                item = self._queue.get()
                if item is _STOP:
                    return
                if isinstance(item, _Begin):
                    failed = None
                    try:
                        episode = _EpisodeBag(self.root, self.schema, self.config, item)
                    except Exception as exc:  # noqa: BLE001 - reported at end_episode
                        episode, failed = None, exc
                elif isinstance(item, _Queued):
                    if episode is not None and episode.error is None:
                        try:
                            episode.write_frame(item.frame, {k: f.result() for k, f in item.encoded.items()})
                        except Exception as exc:  # noqa: BLE001 - reported at end_episode
                            episode.error = exc
                elif isinstance(item, _End):
                    if episode is None:
                        self._results.put(OpenralError(f"{self.root}: cannot start the episode's bag: {failed}"))
                        continue
                    try:
                        self._results.put(episode.finish(item.success))
                    except Exception as exc:  # noqa: BLE001 - handed to the producer thread
                        episode.abort()
                        self._results.put(exc)
                    episode = None
                elif item is _ABORT:
                    if episode is not None:
                        episode.abort()
                    episode = None
                    self._results.put(None)
        except BaseException as exc:
            self._error = exc
            if episode is not None:
                episode.abort()
            raise


class _EpisodeBag:
    """One episode's bag, staged under ``.partial/`` until it is complete."""

    def __init__(self, root: Path, schema: DatasetSchema, config: McapConfig, begin: _Begin) -> None:
        self.schema = schema
        self.config = config
        self.index = begin.index
        self.seed = begin.start.seed
        self.base_ns = begin.base_ns
        self.final = episode_dir(root, begin.index)
        self.staged = root / PARTIAL / self.final.name
        shutil.rmtree(self.staged, ignore_errors=True)
        self.staged.parent.mkdir(parents=True, exist_ok=True)
        self.factory = MessageFactory(config.image_format, config.jpeg_quality)
        self.writer = Writer(self.staged, version=ROSBAG2_VERSION, storage_plugin=StoragePlugin.MCAP)
        self.writer.set_custom_data("openral.episode_index", str(begin.index))
        self.writer.set_custom_data("openral.stamp_base_ns", str(begin.base_ns))
        self.writer.open()
        store = self.factory.store
        add = self.writer.add_connection
        self.c_event = add(m.EPISODE, m.STRING_T, typestore=store)
        self.c_task = add(m.TASK, m.STRING_T, typestore=store)
        self.c_state = add(m.JOINT_STATES, m.JOINT_STATE_T, typestore=store)
        self.c_action = add(m.ACTION, m.FLOAT32_ARRAY_T, typestore=store)
        self.c_reward = add(m.REWARD, m.FLOAT32_T, typestore=store)
        fmt = config.image_format
        self.c_cams: dict[str, Connection] = {
            name: add(m.camera_topic(name, fmt), m.camera_type(fmt), typestore=store) for name in schema.cameras
        }
        self.names = list(schema.state_names)
        self.length = 0
        self.last_ns = begin.base_ns
        self.task: str | None = None
        self.error: BaseException | None = None
        self.closed = False
        start: dict[str, Any] = {
            "event": "start",
            "episode": self.index,
            "seed": self.seed,
            "fps": schema.fps,
            "robot_type": schema.robot_type,
            "state_names": list(schema.state_names),
            "action_names": list(schema.action_names),
            "cameras": list(schema.cameras),
            "initial_state": begin.start.initial_state,
        }
        self.writer.write(self.c_event, self.base_ns, self.factory.event(start))

    def write_frame(self, frame: Frame, encoded: dict[str, bytes]) -> None:
        ns = self.base_ns + round(frame.timestamp * 1e9)
        ns = max(ns, self.last_ns)  # the bridge guarantees non-decreasing time; rounding must not undo it
        self.last_ns = ns
        w, f = self.writer, self.factory
        if frame.task != self.task:
            self.task = frame.task
            w.write(self.c_task, ns, f.string(frame.task))
        w.write(self.c_state, ns, f.joint_state(ns, self.names, frame.state))
        for name, conn in self.c_cams.items():
            w.write(conn, ns, f.image(ns, name, frame.images[name], encoded.get(name)))
        w.write(self.c_action, ns, f.action(frame.action))
        w.write(self.c_reward, ns, f.float32(frame.reward))
        self.length += 1

    def finish(self, success: bool) -> EpisodeRecord:
        if self.error is not None:
            raise OpenralError(f"episode {self.index}: MCAP write failed: {self.error}") from self.error
        end = {"event": "end", "episode": self.index, "success": bool(success), "length": self.length}
        # 1 ns after the last frame, so readers that order equal stamps arbitrarily still see it last
        self.writer.write(self.c_event, self.last_ns + 1, self.factory.event(end))
        self.writer.close()
        self.closed = True
        if self.config.durable:
            for p in self.staged.iterdir():
                fsync_file(p)
            fsync_dir(self.staged)
        os.replace(self.staged, self.final)
        if self.config.durable:
            fsync_dir(self.final.parent)
        return EpisodeRecord(index=self.index, length=self.length, success=bool(success), seed=self.seed)

    def abort(self) -> None:
        if not self.closed:
            self.closed = True
            with contextlib.suppress(Exception):  # the staged bag is deleted anyway
                self.writer.close()
        shutil.rmtree(self.staged, ignore_errors=True)
