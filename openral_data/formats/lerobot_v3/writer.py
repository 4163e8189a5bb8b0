"""LeRobotDataset v3 writer built on pyarrow + PyAV (not lerobot's writer).

Durability: every finished episode is committed before `end_episode` returns. Its videos are complete mp4s,
its frames and its meta/episodes row land in files of their own (temp file, fsync, rename), its digests in a
delta of their own, and `meta/info.json` — whose totals decide what lerobot's loader exposes — is written last.
Those renames are journaled (``.openral/journal.json``), so a crash in the middle of them is finished by
`recovery.recover` (which `record --resume` and `doctor --repair` run) and lerobot meanwhile sees the previous
episode count. A commit therefore costs O(that episode), however large the dataset has grown.

The per-episode data and meta/episodes files of consecutive episodes are joined into the first of them (one
row group per episode, lerobot's rotated layout) when the data file reaches its size limit, every
`WriterConfig.staged_episodes` episodes, and at `close()`; per-episode mp4s of one camera likewise when a video
file fills up and at `close()`, without re-encoding. Each step of a join leaves every episode readable.
`commit_episode` commits an episode made elsewhere (frame columns and mp4s ready, as `edit` assembles them)
the same way. `resume=True` continues an existing dataset of the same format (see `restore`).
"""

from __future__ import annotations

import copy
import json
import logging
import shutil
import time
from collections.abc import Callable
from collections.abc import Mapping as MappingOf
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pyarrow as pa

from openral_data.errors import (
    DISK_ERRNOS,
    CompatibilityError,
    ContractViolation,
    DiskError,
    OutputExists,
    WriteError,
    disk_errno,
)
from openral_data.formats import atomic
from openral_data.formats.lerobot_v3 import digests, layout
from openral_data.formats.lerobot_v3.depth import (
    CameraStats,
    DepthSettings,
    DepthStream,
    camera_stats,
    merge_camera_stats,
)
from openral_data.formats.lerobot_v3.features import (
    ACTION,
    IMAGE_STRUCT,
    STATE,
    build_features,
    data_schema,
    episodes_schema,
    writer_camera_keys,
)
from openral_data.formats.lerobot_v3.images import ENVIRONMENT_STATE
from openral_data.formats.lerobot_v3.layout import FilePos, FileRun
from openral_data.formats.lerobot_v3.masks import MaskColumn
from openral_data.formats.lerobot_v3.provenance import Origin, Provenance
from openral_data.formats.lerobot_v3.reader import read_info
from openral_data.formats.lerobot_v3.restore import check_same_format, restore
from openral_data.formats.lerobot_v3.stats import (
    Stats,
    merge_numeric,
    numeric_stats,
    to_jsonable,
)
from openral_data.formats.lerobot_v3.video import EncodedEpisode, EncoderWorker, VideoSettings, concat_mp4
from openral_data.types import DatasetSchema, EpisodeRecord, EpisodeStart, Frame

MB = 1 << 20
log = logging.getLogger(__name__)


@dataclass(frozen=True)
class WriterConfig:
    video: VideoSettings = field(default_factory=VideoSettings)
    depth: DepthSettings = field(default_factory=DepthSettings)  # the quantizer of depth cameras (lerobot's)
    data_files_size_in_mb: int = 100
    video_files_size_in_mb: int = 200
    chunks_size: int = layout.DEFAULT_CHUNKS_SIZE
    durable: bool = True
    queue_size: int = 16
    # committed episodes whose data and meta/episodes rows stay in files of their own (a commit then costs
    # O(that episode)) before they are joined into the run's first file; a data rotation and close() join too
    staged_episodes: int = 1000

    def __post_init__(self) -> None:
        if self.staged_episodes < 1:
            raise ValueError("staged_episodes must be at least 1")


@dataclass
class _VideoMember:
    episode: int
    pos: FilePos
    frames: int
    size: int


@dataclass
class _VideoGroup:
    """Episodes of one camera that will share one mp4 (each in its own file until joined)."""

    first: FilePos
    members: list[_VideoMember] = field(default_factory=list)

    @property
    def size(self) -> int:
        return sum(m.size for m in self.members)

    def next_pos(self, chunks_size: int) -> FilePos:
        return self.members[-1].pos.next(chunks_size) if self.members else self.first


@dataclass
class _State:
    """What an episode's commit advances; restored when the commit fails before its commit point."""

    tasks: dict[str, int]
    tasks_written: int
    total_frames: int
    episode_rows: list[dict[str, Any]]
    data_run: FileRun
    episodes_run: FileRun
    groups: dict[str, _VideoGroup]
    numeric_stats: dict[str, Stats]
    image_stats: dict[str, CameraStats]


@dataclass
class EpisodeBuffer:
    """One episode's frame columns (one entry per frame) and what its meta/episodes row needs besides them."""

    start: EpisodeStart
    states: list[npt.NDArray[np.float32]] = field(default_factory=list)
    actions: list[npt.NDArray[np.float32]] = field(default_factory=list)
    rewards: list[float] = field(default_factory=list)
    dones: list[bool] = field(default_factory=list)
    successes: list[bool] = field(default_factory=list)
    task_indices: list[int] = field(default_factory=list)
    extras: dict[str, list[float]] = field(default_factory=dict)
    environment_states: list[npt.NDArray[np.float32]] = field(default_factory=list)  # with environment_state_names
    info: dict[str, Any] | None = None
    # whole columns of features the writer does not build itself (only with the writer's `features`; editing
    # carries e.g. `observation.environment_state` this way), each of the feature's Arrow type
    columns: dict[str, pa.Array] = field(default_factory=dict)
    # the episode statistics of those columns that are not numbers (a `dtype: image` feature's, as its source
    # has them): used instead of statistics computed from the column, and merged into the dataset's
    column_stats: dict[str, Stats] = field(default_factory=dict)
    # segmentation masks being recorded (the schema's `segmentation` cameras): PNGs that become `columns`
    masks: dict[str, MaskColumn] = field(default_factory=dict)


class LeRobotV3Writer:
    """A `Sink` that writes a LeRobotDataset v3 that lerobot 0.6.1 loads frame-exactly."""

    def __init__(
        self,
        root: Path,
        schema: DatasetSchema,
        config: WriterConfig | None = None,
        *,
        resume: bool = False,
        image_stats: MappingOf[str, CameraStats] | None = None,
        features: dict[str, dict[str, Any]] | None = None,
    ) -> None:
        """`image_stats`: the per-camera accumulators of the dataset's image statistics (default: empty
        histograms); `image_stats` may also be replaced before `close()`, whose metadata write uses it.
        `features`: the info.json features to write instead of the ones built from `schema` (editing keeps a
        source's own layout): the same columns, camera `info` blocks as the source wrote them, and `next.done`
        only if the source has it (the caller checks this, see `edit.source`). A camera's video files, episode
        columns and statistics use its key in `features` (`features.writer_camera_keys`: a source's
        `observation.image` stays), else `observation.images.<name>`."""
        self.root = root
        self.schema = schema
        self.config = config or WriterConfig()
        # video cameras (colour, depth) and segmentation masks (a `dtype: image` column each, masks.py)
        self._videos = {n: s for n, s in schema.cameras.items() if not s.segmentation}
        self._masks = [n for n, s in schema.cameras.items() if s.segmentation]
        for name, shape in self._videos.items():
            problem = (
                self.config.video.size_problem(shape.height, shape.width)
                if shape.depth_unit is None
                else self.config.depth.size_problem(shape.height, shape.width)
            )
            if problem:
                raise CompatibilityError(f"camera {name}: {problem}")
        if not resume and root.exists() and (not root.is_dir() or any(_dataset_entries(root))):
            raise OutputExists(f"{root}: output exists and is not empty; refusing to overwrite it")
        self._created_root = not root.exists()
        root.mkdir(parents=True, exist_ok=True)
        # a camera's files and columns are named by its key in `features` (a source's `observation.image`)
        self._keys = writer_camera_keys(self._videos, features)
        self._mask_keys = writer_camera_keys(self._masks, features)
        self.features = (
            features
            if features is not None
            else build_features(schema, self.config.video, self.config.depth, self._keys)
        )
        self._data_schema = data_schema(self.features)
        self._episodes_schema = episodes_schema(self.features)
        self._workers = {
            name: EncoderWorker(
                name,
                self.config.video,
                schema.fps,
                self.config.queue_size,
                None if shape.depth_unit is None else DepthStream(self.config.depth, shape.depth_unit),
            )
            for name, shape in self._videos.items()
        }
        self.tasks: dict[str, int] = {}
        self._tasks_written = 0
        self.total_frames = 0
        self.episode_rows: list[dict[str, Any]] = []
        # the data and meta/episodes files of the episodes not consolidated yet (see `_consolidate`)
        self._data_run = FileRun(FilePos())
        self._episodes_run = FileRun(FilePos())
        self._placed: list[Path] = []  # the mp4s the episode being committed moved into place
        self._groups = {name: _VideoGroup(FilePos()) for name in self._videos}
        self._numeric_stats: dict[str, Stats] = {}
        self.image_stats: dict[str, CameraStats] = (
            dict(image_stats)
            if image_stats is not None
            else {n: camera_stats(shape.depth_unit) for n, shape in self._videos.items()}
        )
        # dataset-level statistics written instead of the merged ones (editing's exact `dtype: image` histograms)
        self.stats_override: dict[str, Stats] = {}
        self._episode: EpisodeBuffer | None = None
        self._batch: atomic.Batch | None = None  # set while an episode is being committed
        self._closed = False
        self._failed = False  # a write failed: nothing more is written (see `commit_episode`)
        if resume and (root / layout.INFO_PATH).is_file():
            self._restore()
            return
        atomic.write_bytes(
            root / layout.OPENRAL_PATH,
            Provenance(Origin.from_json(schema.metadata), self._config_json()).dumps(),
            self.config.durable,
        )

    def _restore(self) -> None:
        """Continue a recovered dataset: same format, numbering, open files and running statistics."""
        info = read_info(self.root)
        check_same_format(self.root, info, self.schema.fps, self.features)
        limit = self.config.video_files_size_in_mb * MB
        state = restore(
            self.root,
            self._data_schema,
            self._keys,
            self.config.chunks_size,
            limit,
            self.config.data_files_size_in_mb * MB,
        )
        self.tasks = dict(state.tasks)
        self._tasks_written = len(self.tasks)
        self.episode_rows = state.rows
        self.total_frames = state.total_frames
        self._data_run = state.data_run
        self._episodes_run = state.episodes_run
        for name, tail in state.videos.items():
            members = [_VideoMember(ep, pos, frames, size) for ep, pos, frames, size in tail.members]
            self._groups[name] = _VideoGroup(tail.first, members)
        self._numeric_stats = state.numeric_stats
        self.image_stats.update(state.image_stats)

    def _config_json(self) -> dict[str, Any]:
        c = self.config
        return {
            "codec": c.video.codec,
            "crf": c.video.crf,
            "g": c.video.g,
            "data_files_size_in_mb": c.data_files_size_in_mb,
            "video_files_size_in_mb": c.video_files_size_in_mb,
            "chunks_size": c.chunks_size,
        }

    @property
    def total_episodes(self) -> int:
        return len(self.episode_rows)

    @property
    def closed(self) -> bool:
        return self._closed

    # -- Sink API --------------------------------------------------------------------------------------------
    def begin_episode(self, start: EpisodeStart) -> None:
        if self._episode is not None:
            raise RuntimeError("begin_episode() while an episode is open")
        self._episode = EpisodeBuffer(start, masks={name: MaskColumn() for name in self._masks})
        for name, worker in self._workers.items():
            shape = self.schema.cameras[name]
            worker.begin(self.pending_video(name), shape.height, shape.width)

    def add_frame(self, frame: Frame) -> None:
        ep = self._episode
        if ep is None:
            raise RuntimeError("add_frame() outside an episode")
        width, env = len(self.schema.environment_state_names), frame.environment_state
        if width and (env is None or env.shape != (width,)):  # the bridge checks this; a direct caller may not
            got = "none" if env is None else f"shape {list(env.shape)}"
            raise ContractViolation(f"observation.environment_state: expected float32[{width}], got {got}")
        for name, worker in self._workers.items():
            worker.put(frame.images[name])  # blocks while the encoder is behind: backpressure, never a drop
        for name, column in ep.masks.items():
            column.add(frame.images[name])
        ep.states.append(frame.state)
        ep.actions.append(frame.action)
        ep.rewards.append(frame.reward)
        ep.dones.append(frame.done)
        ep.successes.append(frame.success)
        ep.task_indices.append(self.tasks.setdefault(frame.task, len(self.tasks)))
        for key in self.schema.frame_extras:
            ep.extras.setdefault(key, []).append(frame.extras[key])
        if width and env is not None:
            ep.environment_states.append(env)

    def annotate_episode(self, info: dict[str, Any]) -> None:
        """Store `info` (JSON) in the episode's `openral.episode_info` column of meta/episodes."""
        if self._episode is None:
            raise RuntimeError("annotate_episode() outside an episode")
        self._episode.info = info

    def discard_episode(self) -> None:
        if self._episode is None:
            return
        self._episode = None
        for worker in self._workers.values():
            worker.abort()
        # tasks first seen in the discarded episode must not reach tasks.parquet
        used = {t for row in self.episode_rows for t in row["tasks"]}
        self.tasks = {t: i for t, i in self.tasks.items() if t in used}

    def end_episode(self, success: bool | None) -> EpisodeRecord:
        ep = self._episode
        if ep is None:
            raise RuntimeError("end_episode() outside an episode")
        n = len(ep.states)
        if n == 0:
            self.discard_episode()
            raise ContractViolation("an episode needs at least one frame")
        encoded: dict[str, EncodedEpisode] = {}
        t0 = time.perf_counter()
        try:
            for name, worker in self._workers.items():
                encoded[name] = worker.finish()
        except BaseException as exc:
            for enc in encoded.values():
                enc.path.unlink(missing_ok=True)
            self.discard_episode()  # aborts the cameras not finished yet
            problem = disk_errno(exc)
            if problem is not None:
                self._failed = True
                raise DiskError(self.root, problem, f"encoding episode {self.total_episodes}'s videos") from exc
            raise
        self._episode = None
        for name, column in ep.masks.items():
            ep.columns[self._mask_keys[name]] = column.array(IMAGE_STRUCT)
            ep.column_stats[self._mask_keys[name]] = column.stats()
        short = {name: enc.frames for name, enc in encoded.items() if enc.frames != n}
        if short:
            for enc in encoded.values():
                enc.path.unlink(missing_ok=True)
            raise WriteError(f"episode discarded: encoded frames {short} differ from its {n} rows")
        t1 = time.perf_counter()
        record = self.commit_episode(ep, success, encoded)
        self._log_commit(record.index, (t1 - t0) * 1000, (time.perf_counter() - t1) * 1000)
        return record

    def _log_commit(self, index: int, flush_ms: float, commit_ms: float) -> None:
        """INFO: the episode's commit time and how long its frames waited on full encoder queues (all cameras);
        DEBUG: the waits per camera."""
        waited = {name: round(w.waited * 1000, 1) for name, w in self._workers.items()}
        waits = sum(w.waits for w in self._workers.values())
        log.info(
            "episode %d committed in %.0f ms (encoders flushed in %.0f ms; frames waited %.0f ms on full encoder "
            "queues, %d times)",
            index,
            flush_ms + commit_ms,
            flush_ms,
            sum(waited.values()),
            waits,
            extra={
                "episode": index,
                "flush_ms": round(flush_ms, 1),
                "commit_ms": round(commit_ms, 1),
                "encoder_wait_ms": round(sum(waited.values()), 1),
                "encoder_waits": waits,
            },
        )
        for name, w in self._workers.items():
            log.debug(
                "episode %d camera %s: waited %.1f ms on a full encoder queue, %d times",
                index,
                name,
                waited[name],
                w.waits,
                extra={"episode": index, "camera": name, "encoder_wait_ms": waited[name], "encoder_waits": w.waits},
            )

    def commit_episode(
        self,
        ep: EpisodeBuffer,
        success: bool | None,
        encoded: dict[str, EncodedEpisode],
        *,
        journal: bool = True,
    ) -> EpisodeRecord:
        """Commit an episode whose frame columns and encoded videos are already built, as `end_episode` does.

        Each `encoded[camera]` is an mp4 at `pending_video(camera)` of exactly the episode's frames, with its
        image statistics; the task indices are those of `tasks`. `journal=False` commits without the commit
        journal (for a dataset nobody sees before it is complete).
        """
        index = self.total_episodes
        if self._failed:
            for enc in encoded.values():
                enc.path.unlink(missing_ok=True)
            raise WriteError(f"{self.root}: an earlier write failed; episode {index} is not committed")
        path = self.root / layout.JOURNAL_PATH if journal else None
        batch = self._batch = atomic.Batch(self.config.durable, journal=path)
        saved: _State | None = None
        self._placed = []
        try:
            self._maybe_consolidate(len(ep.states))
            self._rotate_videos(encoded)
            saved = self._state()
            record = self._commit_episode(ep, len(ep.states), success, encoded)
            batch.commit()
        except OSError as exc:
            self._batch = None
            committed = self._fail(batch, saved, encoded, path, index)
            raise _write_error(self.root, exc, f"committing episode {index}", committed) from exc
        except BaseException:
            self._batch = None
            self._fail(batch, saved, encoded, path, index)
            raise
        self._batch = None
        batch.discard()
        return record

    def _fail(
        self,
        batch: atomic.Batch,
        saved: _State | None,
        encoded: dict[str, EncodedEpisode],
        journal: Path | None,
        index: int,
    ) -> bool:
        """After an episode commit failed: mark the writer failed (`close()` then writes nothing more).

        Before the commit point (no durable journal) the episode is undone: staged files and its placed videos
        are removed and the writer state is what it was before the episode. After it (a durable journal names
        the renames, or info.json already counts the episode) the staged files stay for `recovery.recover` to
        finish the commit. Returns whether the episode is committed (now or by that recovery).
        """
        self._failed = True
        if (journal is not None and journal.is_file()) or self._on_disk_episodes() > index:
            return True
        batch.discard()
        for name, enc in encoded.items():
            enc.path.unlink(missing_ok=True)
            if saved is not None:  # a video placed by this commit: no committed row names it
                group = saved.groups[name]
                layout.video_path(self.root, self._keys[name], group.next_pos(self.config.chunks_size)).unlink(
                    missing_ok=True
                )
        if saved is not None:
            self._set_state(saved)
        return False

    def _on_disk_episodes(self) -> int:
        """info.json's episode count as it is on disk now (it lands last: counted means fully renamed)."""
        try:
            return int(read_info(self.root).get("total_episodes", 0))
        except Exception:  # noqa: BLE001 - unreadable or missing: nothing beyond what we know is counted
            return -1

    def _state(self) -> _State:
        return _State(
            tasks=dict(self.tasks),
            tasks_written=self._tasks_written,
            total_frames=self.total_frames,
            episode_rows=list(self.episode_rows),
            data_run=self._data_run.copy(),
            episodes_run=self._episodes_run.copy(),
            groups={n: _VideoGroup(g.first, list(g.members)) for n, g in self._groups.items()},
            numeric_stats=dict(self._numeric_stats),
            image_stats=copy.deepcopy(self.image_stats),
        )

    def _set_state(self, s: _State) -> None:
        used = {t for row in s.episode_rows for t in row["tasks"]}
        self.tasks = {t: i for t, i in s.tasks.items() if t in used}
        self._tasks_written = s.tasks_written
        self.total_frames = s.total_frames
        self.episode_rows = s.episode_rows
        self._data_run = s.data_run
        self._episodes_run = s.episodes_run
        self._groups = s.groups
        self._numeric_stats = s.numeric_stats
        self.image_stats = s.image_stats

    def _commit_episode(
        self, ep: EpisodeBuffer, n: int, success: bool | None, encoded: dict[str, EncodedEpisode]
    ) -> EpisodeRecord:
        """Place the episode's videos, then stage its data file, tasks, stats, its episodes file, the digests
        of all of them and info.json (each episode's data and meta/episodes row in a file of its own)."""
        index = self.total_episodes
        if not self.schema.has_success:
            success = None  # unknown stays unknown: `openral.success` is NULL
        row = self._base_row(index, ep, n, success)
        table = self._episode_table(index, ep, n)
        ep_stats = {
            k: ep.column_stats[k] if k in ep.column_stats else numeric_stats(_column_values(table, k))
            for k in table.column_names
        }
        for name, enc in encoded.items():
            self._place_video(name, index, enc.path, enc.frames, row)
            img = enc.stats.stats()
            ep_stats[self._keys[name]] = img
            merge_camera_stats(self.image_stats[name], enc.stats)
        for key, s in ep_stats.items():
            for stat, value in to_jsonable(s).items():
                row[f"stats/{key}/{stat}"] = value
        self._stage_data(table, row)
        pos = self._episodes_run.next_pos(self.config.chunks_size)
        row["meta/episodes/chunk_index"] = pos.chunk
        row["meta/episodes/file_index"] = pos.file
        self.episode_rows.append(row)
        for key, s in ep_stats.items():
            if key not in self._keys.values():
                self._numeric_stats[key] = merge_numeric(self._numeric_stats.get(key), s)
        self.total_frames += n
        self._write_meta(episode=index)
        return EpisodeRecord(index=index, length=n, success=success, seed=ep.start.seed)

    def close(self) -> None:
        if self._closed:
            return
        self._closed = True
        try:
            if self._episode is not None:
                self.discard_episode()
            if not self._failed:  # after a failed write the committed dataset stays exactly as it is
                self._finish()
        finally:
            for worker in self._workers.values():
                worker.close()
        if self.total_episodes == 0 and not self._failed:  # nothing finished: leave no half-made dataset behind
            if self._created_root:
                shutil.rmtree(self.root, ignore_errors=True)
            else:
                for sub in ("meta", "data", "videos"):
                    shutil.rmtree(self.root / sub, ignore_errors=True)
                (self.root / layout.IMAGE_HIST_PATH).unlink(missing_ok=True)

    def _finish(self) -> None:
        """Join each camera's per-episode files and rewrite the metadata; a disk error stops it (every step of
        a join leaves each episode readable) and leaves the rest as it is."""
        doing = "finishing the dataset"
        try:
            if len(self._episodes_run.positions) > 1 or len(self._data_run.positions) > 1:
                doing = "joining the episodes' data files"
                self._consolidate(rotate=False)
            for name in list(self._groups):
                doing = f"joining the videos of camera {name}"
                self._join_group(name)
            if self.total_episodes:
                doing = "writing the dataset's metadata"
                self._write_meta()
        except OSError as exc:
            self._failed = True
            raise _write_error(self.root, exc, doing) from exc

    # -- episode assembly ------------------------------------------------------------------------------------
    def _base_row(self, index: int, ep: EpisodeBuffer, n: int, success: bool | None) -> dict[str, Any]:
        inv = {i: t for t, i in self.tasks.items()}
        return {
            "episode_index": index,
            "tasks": sorted({inv[i] for i in ep.task_indices}),
            "length": n,
            "dataset_from_index": self.total_frames,
            "dataset_to_index": self.total_frames + n,
            "openral.success": None if success is None else bool(success),
            "openral.seed": None if ep.start.seed is None else int(ep.start.seed),
            "openral.initial_state": json.dumps(ep.start.initial_state, sort_keys=True),
            "openral.episode_info": None if ep.info is None else json.dumps(ep.info, sort_keys=True),
        }

    def _episode_table(self, index: int, ep: EpisodeBuffer, n: int) -> pa.Table:
        fps = self.schema.fps
        frame_index = np.arange(n, dtype=np.int64)
        cols: dict[str, pa.Array] = {
            STATE: _fixed_list(np.stack(ep.states)),
            ACTION: _fixed_list(np.stack(ep.actions)),
            "timestamp": pa.array((frame_index / fps).astype(np.float32)),
            "frame_index": pa.array(frame_index),
            "episode_index": pa.array(np.full(n, index, dtype=np.int64)),
            "index": pa.array(self.total_frames + frame_index),
            "task_index": pa.array(np.asarray(ep.task_indices, dtype=np.int64)),
        }
        if "next.done" in self.features:
            cols["next.done"] = pa.array(np.asarray(ep.dones, dtype=bool))
        if self.schema.has_reward:
            cols["next.reward"] = pa.array(np.asarray(ep.rewards, dtype=np.float32))
        if self.schema.has_success:
            cols["next.success"] = pa.array(np.asarray(ep.successes, dtype=bool))
        for key in self.schema.frame_extras:
            cols[key] = pa.array(np.asarray(ep.extras.get(key, []), dtype=np.float32))
        if self.schema.environment_state_names:
            cols[ENVIRONMENT_STATE] = _fixed_list(np.stack(ep.environment_states))
        cols.update(ep.columns)
        return pa.table(cols, schema=self._data_schema)

    # -- data and meta/episodes files: one per episode, joined later ----------------------------------------
    def _stage_data(self, table: pa.Table, row: dict[str, Any]) -> None:
        """The episode's frames as a data file of its own (one row group, as lerobot writes an episode)."""
        pos = self._data_run.next_pos(self.config.chunks_size)
        row["data/chunk_index"] = pos.chunk
        row["data/file_index"] = pos.file
        written = self._write(layout.data_path(self.root, pos), atomic.parquet_writer(table))
        self._data_run.add(pos, written.stat().st_size, table.num_rows)

    def _maybe_consolidate(self, frames: int) -> None:
        """Before an episode's commit: join the runs when the data file would outgrow its size limit with this
        episode (the episode then starts the next file), or when `staged_episodes` episodes wait in files of
        their own. The join is a commit of its own."""
        data = self._data_run
        limit = self.config.data_files_size_in_mb * MB
        if data.positions and data.size + data.size / max(data.total_rows, 1) * frames >= limit:
            self._consolidate(rotate=True)
        elif len(self._episodes_run.positions) > self.config.staged_episodes:
            self._consolidate(rotate=False)

    def _consolidate(self, rotate: bool) -> None:
        """Join the data run into its first file and the episodes run into its first file, rows re-pointed.

        Every step leaves a dataset lerobot loads exactly: the joined data file replaces the first (its rows
        now also sit, the same, in the later files, which sort after it: rows beyond info.json's total), then
        the joined episodes file (the later files' rows likewise trail), then the later files go. The files
        are listed first (`digests.mark`), so a crash in between leaves recovery what to re-hash.
        `rotate`: the data file is full; the next episode starts the next file.
        """
        cs = self.config.chunks_size
        data, eps = self._data_run, self._episodes_run
        dest_data = layout.data_path(self.root, data.first)
        dest_eps = layout.episodes_path(self.root, eps.first)
        later = [layout.data_path(self.root, p) for p in data.positions[1:]]
        later += [layout.episodes_path(self.root, p) for p in eps.positions[1:]]
        changed = [*([dest_data] if data.positions else []), *([dest_eps] if eps.positions else []), *later]
        digests.mark(self.root, changed, self.config.durable)
        if len(data.positions) > 1:
            sources = [layout.data_path(self.root, p) for p in data.positions]
            atomic.write_with(dest_data, atomic.concat_parquet_writer(sources, self._data_schema), self.config.durable)
        moved_data, moved_eps = set(data.positions[1:]), set(eps.positions[1:])
        tail = self.episode_rows[len(self.episode_rows) - eps.total_rows :]  # the rows in the episodes run
        repointed = False
        for row in tail:
            if layout.row_pos(row, "data") in moved_data:
                row["data/chunk_index"], row["data/file_index"] = data.first.chunk, data.first.file
                repointed = True
            if layout.row_pos(row, "meta/episodes") in moved_eps:
                row["meta/episodes/chunk_index"], row["meta/episodes/file_index"] = eps.first.chunk, eps.first.file
        if len(eps.positions) > 1 or repointed:  # (one episodes file whose rows now name the joined data file)
            table = pa.Table.from_pylist(tail, schema=self._episodes_schema)
            atomic.write_with(dest_eps, atomic.parquet_writer(table), self.config.durable)
        for path in later:
            path.unlink(missing_ok=True)
        if self.config.durable:
            for parent in dict.fromkeys(p.parent for p in later):
                atomic.fsync_dir(parent)
        digests.refresh(self.root, changed, self.config.durable)
        if rotate:
            self._data_run = FileRun(data.first.next(cs))
        elif data.positions:
            self._data_run = FileRun(data.first, [data.first], [dest_data.stat().st_size], [data.total_rows])
        if eps.positions:
            eps_size = dest_eps.stat().st_size
            if eps_size >= self.config.data_files_size_in_mb * MB:
                self._episodes_run = FileRun(eps.first.next(cs))
            else:
                self._episodes_run = FileRun(eps.first, [eps.first], [eps_size], [eps.total_rows])

    # -- videos ----------------------------------------------------------------------------------------------
    def pending_video(self, name: str) -> Path:
        """Where camera `name`'s mp4 of the next episode is made; committing the episode moves it into place."""
        group = self._groups[name]
        return atomic.tmp_name(layout.video_path(self.root, self._keys[name], group.next_pos(self.config.chunks_size)))

    def _place_video(self, name: str, episode: int, tmp: Path, frames: int, row: dict[str, Any]) -> None:
        key = self._keys[name]
        group = self._groups[name]
        size = tmp.stat().st_size
        pos = group.next_pos(self.config.chunks_size)
        final = layout.video_path(self.root, key, pos)
        final.parent.mkdir(parents=True, exist_ok=True)
        atomic.move_into_place(tmp, final, self.config.durable)
        self._placed.append(final)
        group.members.append(_VideoMember(episode, pos, frames, size))
        row[f"videos/{key}/chunk_index"] = pos.chunk
        row[f"videos/{key}/file_index"] = pos.file
        row[f"videos/{key}/from_timestamp"] = 0.0
        row[f"videos/{key}/to_timestamp"] = frames / self.schema.fps

    def _rotate_videos(self, encoded: dict[str, EncodedEpisode]) -> None:
        """A camera whose file would outgrow its size limit with this episode: join its full group first (the
        episode then starts the next file). Done before the episode's commit: the join is a commit of its own."""
        for name, enc in encoded.items():
            group = self._groups[name]
            if group.members and group.size + enc.path.stat().st_size >= self.config.video_files_size_in_mb * MB:
                if len(self._episodes_run.positions) > 1:  # the join re-points rows: one episodes file to rewrite
                    self._consolidate(rotate=False)
                self._join_group(name)

    def _join_group(self, name: str) -> None:
        """Join a camera's per-episode files into the group's first file, then point the episodes at it.

        Order keeps every episode readable at every instant: the first episode stays at timestamp 0 of the
        first file, the others keep their own files until the metadata no longer names them.
        """
        group = self._groups[name]
        key = self._keys[name]
        if len(group.members) > 1:
            dest = layout.video_path(self.root, key, group.first)
            sources = [(layout.video_path(self.root, key, m.pos), m.frames) for m in group.members]
            touched = {layout.row_pos(self.episode_rows[m.episode], "meta/episodes") for m in group.members}
            changed = [dest, *(layout.episodes_path(self.root, pos) for pos in touched), *(p for p, _ in sources[1:])]
            digests.mark(self.root, changed, self.config.durable)
            atomic.write_with(dest, lambda tmp: concat_mp4(sources, tmp, self.schema.fps), self.config.durable)
            offset = 0
            for m in group.members:
                row = self.episode_rows[m.episode]
                row[f"videos/{key}/chunk_index"] = group.first.chunk
                row[f"videos/{key}/file_index"] = group.first.file
                row[f"videos/{key}/from_timestamp"] = offset / self.schema.fps
                offset += m.frames
                row[f"videos/{key}/to_timestamp"] = offset / self.schema.fps
            self._write_episodes(touched)
            for m in group.members[1:]:
                layout.video_path(self.root, key, m.pos).unlink(missing_ok=True)
            # the join replaced files outside a commit batch: their digests follow at once
            digests.refresh(self.root, changed, self.config.durable)
        start = group.first.next(self.config.chunks_size) if group.members else group.first
        self._groups[name] = _VideoGroup(start)

    # -- metadata --------------------------------------------------------------------------------------------
    def _write(self, path: Path, writer: Callable[[Path], None]) -> Path:
        """Stage into the episode's batch while one is being committed, else replace atomically now; returns
        where the bytes are now (the staged file, or `path`)."""
        if self._batch is not None:
            self._batch.write_with(path, writer)
            return atomic.tmp_name(path)
        atomic.write_with(path, writer, self.config.durable)
        return path

    def _write_episodes(self, files: set[FilePos]) -> None:
        """Rewrite whole meta/episodes files now (outside a commit: a video join re-pointed their rows)."""
        for pos in sorted(files):
            rows = [
                r
                for r in self.episode_rows
                if (r["meta/episodes/chunk_index"], r["meta/episodes/file_index"]) == (pos.chunk, pos.file)
            ]
            table = pa.Table.from_pylist(rows, schema=self._episodes_schema)
            atomic.write_with(layout.episodes_path(self.root, pos), atomic.parquet_writer(table), self.config.durable)

    def _write_meta(self, episode: int | None = None) -> None:
        """tasks, stats, then (in episode `episode`'s commit) its meta/episodes file and the digests of what the
        commit wrote, then info.json last: its totals are what the loader trusts.

        The episodes file lands right before info.json: lerobot lists every row of meta/episodes, so the new
        row would show (uncounted) in the moment between those two renames, and only then. Outside a commit
        (close) the files are rewritten one by one and their digests refreshed after them.
        """
        batch = self._batch if episode is not None else None  # in episode `episode`'s commit
        new_tasks = len(self.tasks) != self._tasks_written
        written = [self.root / p for p in (layout.TASKS_PATH, layout.STATS_PATH, layout.INFO_PATH)]
        if batch is None:
            digests.mark(self.root, written if new_tasks else written[1:], self.config.durable)
        if new_tasks:
            self._write(self.root / layout.TASKS_PATH, tasks_writer(self.tasks))
            self._tasks_written = len(self.tasks)
        stats: dict[str, Any] = {}
        for key in self.features:
            if key in self._numeric_stats:
                stats[key] = to_jsonable(self._numeric_stats[key])
        for name, acc in self.image_stats.items():
            stats[self._keys[name]] = to_jsonable(acc.stats())
        stats.update({key: to_jsonable(s) for key, s in self.stats_override.items()})
        ordered = {k: stats[k] for k in self.features if k in stats}
        hist = {name: acc.to_json() for name, acc in self.image_stats.items()}
        self._write(self.root / layout.IMAGE_HIST_PATH, atomic.bytes_writer(json.dumps(hist).encode()))
        self._write(self.root / layout.STATS_PATH, atomic.bytes_writer(json.dumps(ordered, indent=4).encode()))
        info = json.dumps(self.info(), indent=4).encode()
        if batch is not None and episode is not None:
            pos = self._episodes_run.next_pos(self.config.chunks_size)
            table = pa.Table.from_pylist([self.episode_rows[-1]], schema=self._episodes_schema)
            staged = self._write(layout.episodes_path(self.root, pos), atomic.parquet_writer(table, small=True))
            self._episodes_run.add(pos, staged.stat().st_size, 1)
            files = [*batch.staged(), *((p, p) for p in self._placed)]
            delta = digests.delta_path(self.root, episode)
            self._write(delta, digests.delta_writer(self.root, files, {layout.INFO_PATH: info}))
            self._write(self.root / layout.INFO_PATH, atomic.bytes_writer(info))
            return
        self._write(self.root / layout.INFO_PATH, atomic.bytes_writer(info))
        digests.refresh(self.root, written, self.config.durable)

    def info(self) -> dict[str, Any]:
        c = self.config
        return {
            "codebase_version": layout.CODEBASE_VERSION,
            "fps": self.schema.fps,
            "features": self.features,
            "total_episodes": self.total_episodes,
            "total_frames": self.total_frames,
            "total_tasks": len(self.tasks),
            "chunks_size": c.chunks_size,
            "data_files_size_in_mb": c.data_files_size_in_mb,
            "video_files_size_in_mb": c.video_files_size_in_mb,
            "data_path": layout.DATA_PATH,
            "video_path": layout.VIDEO_PATH if self._videos else None,
            "robot_type": self.schema.robot_type,
            "splits": {"train": f"0:{self.total_episodes}"},
        }


def warm_up() -> None:
    """Pay pyarrow's one-time cost now (its first array imports pandas: about half a second): a recording
    calls this while its scene is being built, so its first episode's commit does not."""
    pa.array([0.0])


def _write_error(root: Path, exc: OSError, doing: str, committed: bool = False) -> WriteError:
    """One line for a failed write: a `DiskError` for a disk problem, else a `WriteError` naming the OS error."""
    if exc.errno in DISK_ERRNOS:
        return DiskError(root, exc.errno, doing, committed=committed)
    return WriteError(f"{root}: {exc.strerror or exc} while {doing}")


def _dataset_entries(root: Path) -> list[Path]:
    """What is in `root` besides openral-data's own bookkeeping folder (the lock of the recording taking it)."""
    return [p for p in root.iterdir() if p.name != layout.STATE_DIR]


def _fixed_list(values: npt.NDArray[np.float32]) -> pa.Array:
    """(n, d) float32 -> fixed_size_list<float>[d]; d == 1 is a plain column, as lerobot types shape [1]."""
    flat = pa.array(np.ascontiguousarray(values, dtype=np.float32).ravel())
    return flat if values.shape[1] == 1 else pa.FixedSizeListArray.from_arrays(flat, values.shape[1])


def _column_values(table: pa.Table, key: str) -> npt.NDArray[Any]:
    col = table.column(key).combine_chunks()
    if pa.types.is_fixed_size_list(col.type):
        return np.asarray(col.flatten().to_numpy(zero_copy_only=False)).reshape(len(col), col.type.list_size)
    return np.asarray(col.to_numpy(zero_copy_only=False)).reshape(-1, 1)


def tasks_writer(tasks: dict[str, int]) -> Callable[[Path], None]:
    """tasks.parquet as pandas writes it: column `task_index`, the task string as the index named `task`.

    lerobot reads it with `pd.read_parquet` and looks tasks up by position, so rows are in task_index order
    and the pandas metadata that makes `task` the index is required (without it `item["task"]` is an int).
    """
    ordered = sorted(tasks.items(), key=lambda kv: kv[1])
    pandas_meta = {
        "index_columns": ["task"],
        "column_indexes": [
            {
                "name": None,
                "field_name": None,
                "pandas_type": "unicode",
                "numpy_type": "object",
                "metadata": {"encoding": "UTF-8"},
            }
        ],
        "columns": [
            {
                "name": "task_index",
                "field_name": "task_index",
                "pandas_type": "int64",
                "numpy_type": "int64",
                "metadata": None,
            },
            {"name": "task", "field_name": "task", "pandas_type": "unicode", "numpy_type": "object", "metadata": None},
        ],
        "attributes": {},
        "creator": {"library": "pyarrow", "version": pa.__version__},
        "pandas_version": _pandas_version(),
    }
    schema = pa.schema([("task_index", pa.int64()), ("task", pa.string())]).with_metadata(
        {b"pandas": json.dumps(pandas_meta).encode()}
    )
    table = pa.table({"task_index": [i for _, i in ordered], "task": [t for t, _ in ordered]}, schema=schema)
    return atomic.parquet_writer(table)


def _pandas_version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("pandas")
    except PackageNotFoundError:
        return "2.3.3"
