"""The MCAP sink: one rosbag2 bag (``metadata.yaml`` + ``.mcap``, CDR) per episode, written with rosbags.

Layout under ``root``::

    episode_000000/{metadata.yaml, episode_000000.mcap}
    episode_000001/...
    .partial/episode_000002/...        <- the episode in flight (never read by `convert`)

An episode is written into ``.partial/`` and renamed to ``episode_NNNNNN`` only after rosbags closed the bag
(summary + metadata.yaml) and both files were fsynced; a killed recording therefore leaves every finished
episode complete and the unfinished one out of sight.

Camera images are compressed in the caller's thread (JPEG: ~1 ms at 256², where handing them to threads cost
more CPU and wall time than it saved — measured against a bare rosbags writer) or, for PNG (several ms per
image), in a small encoder pool as each frame arrives (Pillow releases the GIL while encoding); at most
`queue_size` frames wait for their images, beyond that `add_frame` blocks on the oldest (backpressure:
nothing can be dropped). `McapConfig.encoder_threads` overrides the choice.

Chunks are compressed as rosbag2 does by default for MCAP (`McapConfig.compression`, `record/convert
--mcap-compression`): zstd, else lz4 or none. This is storage-level compression (each MCAP chunk is compressed
inside the file), so ``metadata.yaml`` keeps ``compression_format: ''`` / ``compression_mode: ''`` exactly as
rosbag2's MCAP plugin writes it, and every MCAP reader opens the bag as it is.

Stamps: ``episode start wall clock (ns since the epoch, taken at begin_episode) + Frame.timestamp``. The
relative times are the producer's clock (sim time for sim, a monotonic clock for hardware), the absolute
base puts the bag at the moment it was recorded so tools show real dates and episodes never overlap.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import time
from collections import deque
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final, Literal

from lz4.frame import compress as lz4_compress  # type: ignore[import-untyped]
from rosbags.interfaces import Connection
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
from rosbags.rosbag2.storage_mcap import McapWriter

from openral_data.errors import DISK_ERRNOS, DiskError, OutputExists, UsageError, WriteError
from openral_data.formats.atomic import fsync_dir, fsync_file
from openral_data.formats.mcap import messages as m
from openral_data.formats.mcap.messages import ImageFormat, MessageFactory
from openral_data.formats.write_errors import write_error
from openral_data.paths import contained
from openral_data.types import DatasetSchema, EpisodeRecord, EpisodeStart, Frame

PARTIAL = ".partial"
MCAP_SUBDIR = "mcap"  # where a dataset output keeps its bags: OUT/mcap/episode_NNNNNN/
ROSBAG2_VERSION: Final[Literal[8]] = 8  # Humble/Iron readers accept 8; Jazzy reads 8 and 9
McapCompression = Literal["zstd", "lz4", "none"]
MCAP_COMPRESSIONS: tuple[McapCompression, ...] = ("zstd", "lz4", "none")


def bags_dir(out: Path) -> Path:
    """A dataset output's bag folder ``OUT/mcap``, refused in one line if a symlink leads it outside `out`."""
    return contained(out, MCAP_SUBDIR, str(out / MCAP_SUBDIR))


def episode_dir(root: Path, index: int) -> Path:
    """Episode `index`'s bag folder under the bag folder `root`, refused if a symlink leads it outside `root`."""
    name = f"episode_{index:06d}"
    return contained(root, name, str(root / name))


def finished_bags(root: Path) -> list[Path]:
    """The complete episode bags under `root`, in episode order."""
    return sorted(p for p in root.glob("episode_*") if (p / "metadata.yaml").is_file())


@dataclass(frozen=True)
class McapConfig:
    image_format: ImageFormat = "jpeg"
    jpeg_quality: int = 90
    queue_size: int = 16
    durable: bool = True
    # threads compressing camera images; None = automatic (PNG: one per camera up to 4, JPEG: none, i.e. in the
    # caller's thread, which is cheaper for ~1 ms encodes than any hand-off); 0 = always in the caller's thread
    encoder_threads: int | None = None
    compression: McapCompression = "zstd"  # of the MCAP chunks (storage-level, as rosbag2 writes them)

    def threads(self, cameras: int) -> int:
        if self.image_format == "raw":
            return 0
        if self.encoder_threads is not None:
            return self.encoder_threads
        return min(cameras, os.cpu_count() or 1, 4) if self.image_format == "png" else 0


@dataclass
class _Pending:
    frame: Frame
    encoded: dict[str, Future[bytes]]  # camera -> its JPEG/PNG being encoded in the pool (empty for raw)


class McapSink:
    """A `Sink` writing one rosbag2/MCAP bag per episode under `root`.

    Pipeline: without encoder threads `add_frame` compresses and writes the frame before it returns. With
    them, it hands each camera image to the pool and keeps the frame in a bounded list of pending frames;
    once more than `queue_size` are pending, it writes the oldest (waiting for its images if they are not
    encoded yet). Either way the producer waits whenever encoding falls behind: there is nowhere a frame
    could be dropped. Serialising and writing happen in the caller's thread, in frame order; only the
    encoding (which releases the GIL) may run in parallel.
    """

    def __init__(
        self,
        root: Path,
        schema: DatasetSchema,
        config: McapConfig | None = None,
        *,
        resume: bool = False,
        first_index: int = 0,
    ) -> None:
        self.root = root
        self.schema = schema
        self.config = config or McapConfig()
        if self.config.queue_size < 1:
            raise UsageError(f"queue_size must be >= 1, got {self.config.queue_size}")
        if self.config.encoder_threads is not None and self.config.encoder_threads < 0:
            raise UsageError(f"encoder_threads must be >= 0, got {self.config.encoder_threads}")
        if not resume and root.exists() and (not root.is_dir() or any(p.name != PARTIAL for p in root.iterdir())):
            raise OutputExists(f"{root}: output exists and is not empty; refusing to overwrite it")
        self._created_root = not root.exists()
        root.mkdir(parents=True, exist_ok=True)
        # resume: continue after the finished bags (numbered 0..n-1; record --resume checked that)
        self.episodes = len(finished_bags(root)) if resume else 0
        self.first_index = first_index  # the first bag's number (a parallel worker writes its share under final ones)
        self._factory = MessageFactory(self.config.image_format, self.config.jpeg_quality)
        workers = self.config.threads(len(schema.cameras))
        self._pool = ThreadPoolExecutor(workers, thread_name_prefix="mcap-image") if workers > 0 else None
        self._episode: EpisodeBag | None = None
        self._pending: deque[_Pending] = deque()
        self._closed = False

    # -- Sink API --------------------------------------------------------------------------------------------
    def begin_episode(self, start: EpisodeStart, index: int | None = None) -> None:
        """Open the next episode's bag, numbered `index` (an export keeping the source's numbers) or, by default,
        `first_index` + the episodes written so far."""
        if self._episode is not None:
            raise RuntimeError("begin_episode() while an episode is open")
        if index is None:
            index = self.first_index + self.episodes
        if episode_dir(self.root, index).exists():
            raise OutputExists(f"{episode_dir(self.root, index)}: exists; refusing to overwrite it")
        try:
            self._episode = EpisodeBag(self.root, self.schema, self.config, index, start, time.time_ns())
        except OSError as exc:
            if exc.errno in DISK_ERRNOS:
                raise DiskError(self.root, exc.errno, f"starting episode {index}'s bag") from exc
            raise WriteError(f"{self.root}: cannot start episode {index}'s bag: {exc}") from exc

    def add_frame(self, frame: Frame) -> None:
        if self._episode is None:
            raise RuntimeError("add_frame() outside an episode")
        encoded: dict[str, Future[bytes]] = {}
        if self._pool is not None:
            for name, img in frame.images.items():
                shape = self.schema.cameras[name]
                if shape.depth_unit is None and not shape.segmentation:  # depth and masks go out raw
                    encoded[name] = self._pool.submit(self._factory.compress, img)
        self._pending.append(_Pending(frame, encoded))
        while len(self._pending) > (self.config.queue_size if self._pool is not None else 0):
            self._write_oldest()  # waits for the oldest frame's images: backpressure, never a drop

    def end_episode(self, success: bool | None) -> EpisodeRecord:
        episode = self._episode
        if episode is None:
            raise RuntimeError("end_episode() outside an episode")
        try:
            while self._pending:
                self._write_oldest()
            record = episode.finish(success)
        except OSError as exc:  # closing, syncing or renaming the bag
            self.discard_episode()
            done = episode.final.is_dir()  # renamed into place: the bag is complete (only a folder sync failed)
            self.episodes += done
            raise _write_error(self.root, exc, episode.index, "finishing", committed=done) from exc
        except BaseException:
            self.discard_episode()
            raise
        self._episode = None
        self.episodes += 1
        return record

    def annotate_episode(self, info: dict[str, Any]) -> None:
        """Keep `info` (who drove, a HAL's report: the dataset's `openral.episode_info`) for the end marker."""
        if self._episode is None:
            raise RuntimeError("annotate_episode() outside an episode")
        self._episode.info = info

    def discard_episode(self) -> None:
        episode, self._episode = self._episode, None
        for pending in self._pending:
            for future in pending.encoded.values():
                future.cancel()
        self._pending.clear()
        if episode is not None:
            episode.abort()

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        self.discard_episode()
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
        shutil.rmtree(self.root / PARTIAL, ignore_errors=True)
        if self.episodes == 0 and self._created_root:
            shutil.rmtree(self.root, ignore_errors=True)

    def _write_oldest(self) -> None:
        assert self._episode is not None
        pending = self._pending.popleft()
        encoded = {name: future.result() for name, future in pending.encoded.items()}
        try:
            self._episode.write_frame(pending.frame, encoded)
        except OSError as exc:
            raise _write_error(self.root, exc, self._episode.index, "writing") from exc


def parse_compression(name: str) -> McapCompression:
    """`--mcap-compression` (or any untyped text) -> a `McapCompression`; never checked again below the edge."""
    if name not in MCAP_COMPRESSIONS:
        raise UsageError(f"--mcap-compression: {name!r} is not one of {', '.join(MCAP_COMPRESSIONS)}")
    return name


def _compressed_chunks(writer: Writer, compression: McapCompression) -> None:
    """Compress `writer`'s MCAP chunks: zstd through rosbags' own storage compression; lz4 (which rosbags reads
    but does not write) by giving its MCAP storage the LZ4 frame compressor the MCAP spec names ``lz4``.
    Called after `open()`, before the first chunk is closed."""
    if compression != "lz4":
        return
    storage = writer.storage
    assert isinstance(storage, McapWriter)
    storage.compression = "lz4"
    storage.compressor = lz4_compress


def _write_error(root: Path, exc: OSError, index: int, doing: str, committed: bool = False) -> WriteError:
    """`formats.write_errors.write_error` naming episode `index`'s bag (the MCAP write error with the cause)."""
    failed = f"episode {index}: MCAP write failed: {exc}"
    return write_error(root, exc, f"{doing} episode {index}'s bag", committed, message=failed)


class EpisodeBag:
    """One episode's bag, staged under ``.partial/`` until it is complete.

    Public as the sink's fault-injection seam: a test that replaces `EpisodeBag.write_frame` (monkeypatch) makes
    every frame write fail the way a full disk would, in the caller's thread or the encoder path alike.
    """

    def __init__(
        self, root: Path, schema: DatasetSchema, config: McapConfig, index: int, start: EpisodeStart, base_ns: int
    ) -> None:
        self.schema = schema
        self.config = config
        self.index = index
        self.seed = start.seed
        self.base_ns = base_ns
        self.final = episode_dir(root, index)
        self.staged = contained(root, f"{PARTIAL}/{self.final.name}", str(root / PARTIAL))
        self.factory = MessageFactory(config.image_format, config.jpeg_quality)
        self.depth = [name for name, shape in schema.cameras.items() if shape.depth_unit is not None]
        self.masks = [name for name, shape in schema.cameras.items() if shape.segmentation]
        self.names = list(schema.state_names)
        self.length = 0
        self.last_ns = base_ns
        self.task: str | None = None
        self.info: dict[str, Any] | None = None  # `annotate_episode`'s, written in the end marker
        self.closed = False
        self.writer = self._open_writer()
        self._add_connections()
        self._write_start(start)

    def _open_writer(self) -> Writer:
        """The rosbag2 writer of the staged bag, its custom data set and its chunks compressed as configured."""
        shutil.rmtree(self.staged, ignore_errors=True)
        self.staged.parent.mkdir(parents=True, exist_ok=True)
        writer = Writer(self.staged, version=ROSBAG2_VERSION, storage_plugin=StoragePlugin.MCAP)
        writer.set_custom_data("openral.episode_index", str(self.index))
        writer.set_custom_data("openral.stamp_base_ns", str(self.base_ns))
        if self.config.compression == "zstd":
            writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        writer.open()
        _compressed_chunks(writer, self.config.compression)
        return writer

    def _add_connections(self) -> None:
        """One connection per topic, in a fixed order (it is the bag's channel order); /tf waits for the first
        frame that reports a moving camera mount."""
        schema, store, add = self.schema, self.factory.store, self.writer.add_connection
        self.c_event = add(m.EPISODE, m.STRING_T, typestore=store)
        self.c_task = add(m.TASK, m.STRING_T, typestore=store)
        self.c_state = add(m.JOINT_STATES, m.JOINT_STATE_T, typestore=store)
        self.c_action = add(m.ACTION, m.FLOAT32_ARRAY_T, typestore=store)
        # an outcome the source does not know gets no topic (a converted hardware log has no reward)
        self.c_reward = add(m.REWARD, m.FLOAT32_T, typestore=store) if schema.has_reward else None
        env = schema.environment_state_names
        self.c_env = add(m.ENVIRONMENT_STATE, m.FLOAT32_ARRAY_T, typestore=store) if env else None
        # the schema's per-frame columns (an intervention session's proposal and flag); none in a plain recording
        self.c_columns = {
            col.key: add(
                m.column_topic(col.key), m.BOOL_T if col.dtype == "bool" else m.FLOAT32_ARRAY_T, typestore=store
            )
            for col in schema.frame_columns
        }
        fmt = self.config.image_format
        self.intrinsics = {
            name: shape.info["camera_info"] for name, shape in schema.cameras.items() if "camera_info" in shape.info
        }
        self.c_info = {
            name: add(m.camera_info_topic(name), m.CAMERA_INFO_T, typestore=store) for name in self.intrinsics
        }
        self.poses = {
            name: shape.info["extrinsics"] for name, shape in schema.cameras.items() if "extrinsics" in shape.info
        }
        self.c_tf_static = add(m.TF_STATIC, m.TF_T, typestore=store) if self.poses else None
        self.c_cams: dict[str, Connection] = {
            name: (
                add(m.depth_topic(name), m.IMAGE_T, typestore=store)
                if name in self.depth
                else add(m.segmentation_topic(name), m.IMAGE_T, typestore=store)
                if name in self.masks
                else add(m.camera_topic(name, fmt), m.camera_type(fmt), typestore=store)
            )
            for name in schema.cameras
        }
        self.c_tf: Connection | None = None

    def _write_start(self, start: EpisodeStart) -> None:
        """The start marker, then each camera's intrinsics and where each camera is: once, at the first stamp."""
        schema = self.schema
        marker: dict[str, Any] = {
            "event": "start",
            "episode": self.index,
            "seed": self.seed,
            "fps": schema.fps,
            "robot_type": schema.robot_type,
            "state_names": list(schema.state_names),
            "action_names": list(schema.action_names),
            "cameras": [name for name in schema.cameras if name not in self.depth and name not in self.masks],
            # 16UC1 millimetres or 32FC1 metres on depth_topic(name); each with its lerobot quantizer (video.depth_*)
            "depth_cameras": {name: _quantizer(schema.cameras[name].info) for name in self.depth},
            # mono16 object ids on segmentation_topic(name); each with its {"<id>": object name}
            "segmentation_cameras": {
                name: schema.cameras[name].info.get("segmentation_ids", {}) for name in self.masks
            },
            "environment_state_names": list(schema.environment_state_names),
            "initial_state": start.initial_state,
            "outcomes": {"reward": schema.has_reward, "success": schema.has_success},
        }
        if schema.frame_columns:  # a plain recording's marker stays as it was
            marker["frame_columns"] = {
                col.key: {"topic": m.column_topic(col.key), "dtype": col.dtype, "names": list(col.names)}
                for col in schema.frame_columns
            }
        self.writer.write(self.c_event, self.base_ns, self.factory.event(marker))
        for name, conn in self.c_info.items():
            self.writer.write(conn, self.base_ns, self.factory.camera_info(self.base_ns, self.intrinsics[name]))
        if self.c_tf_static is not None:
            self.writer.write(self.c_tf_static, self.base_ns, self.factory.transforms(self.base_ns, self.poses))

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
            if name in self.depth:
                w.write(conn, ns, f.depth_image(ns, name, frame.images[name]))
            elif name in self.masks:
                w.write(conn, ns, f.mask_image(ns, name, frame.images[name]))
            else:
                w.write(conn, ns, f.image(ns, name, frame.images[name], encoded.get(name)))
        if frame.transforms:  # where the moving camera mounts are: /tf, from the first frame that has them
            if self.c_tf is None:
                self.c_tf = self.writer.add_connection(m.TF, m.TF_T, typestore=self.factory.store)
            poses = {
                name: {"parent_frame": "world", "position": pose[:3], "quaternion": pose[3:]}
                for name, pose in frame.transforms.items()
            }
            w.write(self.c_tf, ns, f.transforms(ns, poses))
        w.write(self.c_action, ns, f.action(frame.action))
        if self.c_reward is not None:
            w.write(self.c_reward, ns, f.float32(frame.reward))
        if self.c_env is not None:
            if frame.environment_state is None:
                raise ValueError("frame has no environment_state, the schema names one")  # our bug, not the input
            w.write(self.c_env, ns, f.action(frame.environment_state, label="environment_state"))
        for col in self.schema.frame_columns:
            value = frame.columns[col.key]
            raw = f.boolean(bool(value[0])) if col.dtype == "bool" else f.action(value, label=col.key)
            w.write(self.c_columns[col.key], ns, raw)
        self.length += 1

    def finish(self, success: bool | None) -> EpisodeRecord:
        if not self.schema.has_success:
            success = None
        known = None if success is None else bool(success)
        end: dict[str, Any] = {"event": "end", "episode": self.index, "success": known, "length": self.length}
        if self.info is not None:  # known at the end only (a HAL's report), so it is the end marker's
            end["info"] = self.info
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
        return EpisodeRecord(index=self.index, length=self.length, success=known, seed=self.seed)

    def abort(self) -> None:
        if not self.closed:
            self.closed = True
            with contextlib.suppress(Exception):  # the staged bag is deleted anyway
                self.writer.close()
        shutil.rmtree(self.staged, ignore_errors=True)


def _quantizer(info: dict[str, Any]) -> dict[str, Any]:
    """A depth camera's lerobot quantizer settings from its feature info (`video.depth_min` ... -> `depth_min`)."""
    names = ("depth_min", "depth_max", "shift", "use_log")
    return {n: info[f"video.{n}"] for n in names if f"video.{n}" in info}
