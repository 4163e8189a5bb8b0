"""LeRobotDataset v3 writer built on pyarrow + PyAV (not lerobot's writer).

Durability: every finished episode is committed before `end_episode` returns (with `WriterConfig.background`,
a real-time recording's, after it: in order, on the committer's thread, while the next episode records). Its
videos are complete mp4s, its frames and its meta/episodes row land in files of their own (temp file, fsync,
rename), its digests in a delta of their own, and `meta/info.json` (whose totals decide what lerobot's loader
exposes) is written last.
Those renames are journaled (``.openral/journal.json``), so a crash in the middle of them is finished by
`recovery.recover` (which `record --resume` and `doctor --repair` run) and lerobot meanwhile sees the previous
episode count. A commit therefore costs O(that episode), however large the dataset has grown.

The per-episode data and meta/episodes files of consecutive episodes are joined into the first of them (one
row group per episode, lerobot's rotated layout) when the data file reaches its size limit, every
`WriterConfig.staged_episodes` episodes, and at `close()`; per-episode mp4s of one camera likewise when a video
file fills up and at `close()`, without re-encoding. Each step of a join leaves every episode readable (`joins`).
An episode's columns, table and meta/episodes row are built in `buffer`; tasks.parquet in `tasks_table`.
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
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import pyarrow as pa

from openral_data.errors import CompatibilityError, ContractViolation, WriteError, disk_errno
from openral_data.formats import atomic
from openral_data.formats.lerobot_v3 import digests, joins, layout
from openral_data.formats.lerobot_v3.buffer import EpisodeBuffer, base_row, column_stats, episode_table
from openral_data.formats.lerobot_v3.commit_log import log_commit
from openral_data.formats.lerobot_v3.committer import Committer, wait_videos
from openral_data.formats.lerobot_v3.config import WriterConfig
from openral_data.formats.lerobot_v3.depth import CameraStats, DepthStream, camera_stats, merge_camera_stats
from openral_data.formats.lerobot_v3.encoder import encoder_threads
from openral_data.formats.lerobot_v3.features import (
    IMAGE_STRUCT,
    build_features,
    data_schema,
    episodes_schema,
    writer_camera_keys,
)
from openral_data.formats.lerobot_v3.info import dataset_info
from openral_data.formats.lerobot_v3.joins import Runs, VideoGroup, VideoMember
from openral_data.formats.lerobot_v3.layout import FilePos, FileRun
from openral_data.formats.lerobot_v3.masks import MaskColumn
from openral_data.formats.lerobot_v3.provenance import Origin, Provenance
from openral_data.formats.lerobot_v3.reader import counted_episodes, read_info
from openral_data.formats.lerobot_v3.restore import check_same_format, claim_root, restore
from openral_data.formats.lerobot_v3.stats import Stats, dataset_stats, merge_numeric, to_jsonable
from openral_data.formats.lerobot_v3.tasks_table import tasks_writer
from openral_data.formats.lerobot_v3.video import CAPTURE, EncodedEpisode, EncodeJob, EncoderLag, EncoderWorker
from openral_data.formats.write_errors import write_error
from openral_data.types import DatasetSchema, EpisodeRecord, EpisodeStart, Frame

log = logging.getLogger(__name__)


@dataclass
class _State:
    """What an episode's commit advances; restored when the commit fails before its commit point."""

    tasks: dict[str, int]
    tasks_written: int
    total_frames: int
    episode_rows: list[dict[str, Any]]
    runs: Runs
    numeric_stats: dict[str, Stats]
    image_stats: dict[str, CameraStats]


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
        histograms); `use_image_stats` replaces them before `close()`, whose metadata write uses them.
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
        self._check_cameras()
        self._created_root = claim_root(root, resume)
        self._set_format(features)
        budget, spill = encoder_threads(self.config.video, len(self._videos)), self.config.spill_budget(root)
        self._workers = {
            name: EncoderWorker(
                name,
                self.config.video,
                schema.fps,
                self.config.queue_size,
                None if shape.depth_unit is None else DepthStream(self.config.depth, shape.depth_unit),
                budget,
                spill,
            )
            for name, shape in self._videos.items()
        }
        self._set_empty(image_stats)
        self._committer = Committer() if self.config.background else None
        if resume and (root / layout.INFO_PATH).is_file():
            self._restore()
        else:
            self._write_openral()

    def _check_cameras(self) -> None:
        """Refuse a video camera whose size the codec (or the depth quantizer) cannot encode."""
        for name, shape in self._videos.items():
            if problem := self.config.size_problem(shape):
                raise CompatibilityError(f"camera {name}: {problem}")

    def _set_format(self, features: dict[str, dict[str, Any]] | None) -> None:
        """The dataset's features (given, or built from the schema), camera keys and Arrow schemas."""
        # a camera's files and columns are named by its key in `features` (a source's `observation.image`)
        self._keys = writer_camera_keys(self._videos, features)
        self._mask_keys = writer_camera_keys(self._masks, features)
        self.features = (
            features
            if features is not None
            else build_features(self.schema, self.config.video, self.config.depth, self._keys)
        )
        self._data_schema = data_schema(self.features)
        self._episodes_schema = episodes_schema(self.features)
        c = self.config
        self._target = joins.Target(
            self.root, self.schema.fps, self._keys, self._data_schema, self._episodes_schema, c.chunks_size,
            c.durable, c.data_limit, c.video_limit,
        )  # fmt: skip

    def _set_empty(self, image_stats: MappingOf[str, CameraStats] | None) -> None:
        """The state of a dataset without episodes (`_restore` then continues an existing one)."""
        self.tasks: dict[str, int] = {}
        self._tasks_written = 0
        self.total_frames = 0
        self.episode_rows: list[dict[str, Any]] = []
        # the data, meta/episodes and video files of the episodes not joined yet (see `joins`)
        self._runs = Runs(
            FileRun(FilePos()), FileRun(FilePos()), {name: VideoGroup(FilePos()) for name in self._videos}
        )
        self._placed: list[Path] = []  # the mp4s the episode being committed moved into place
        self._numeric_stats: dict[str, Stats] = {}
        self.image_stats: dict[str, CameraStats] = (
            dict(image_stats)
            if image_stats is not None
            else {n: camera_stats(shape.depth_unit) for n, shape in self._videos.items()}
        )
        # dataset-level statistics written instead of the merged ones (`override_stats`)
        self._stats_override: dict[str, Stats] = {}
        self._episode: EpisodeBuffer | None = None
        self._batch: atomic.Batch | None = None  # set while an episode is being committed
        self._closed = False
        self._failed = False  # a write failed: nothing more is written (see `commit_episode`)
        self._next_index = 0  # with a committer: the index of the next episode `end_episode` hands over
        self._lags: dict[int, dict[str, EncoderLag]] = {}  # each committed episode's `encoder_lag`

    def _write_openral(self) -> None:
        """meta/openral.json of a new dataset: who wrote it, the schema's metadata and the writer's settings."""
        atomic.write_bytes(
            self.root / layout.OPENRAL_PATH,
            Provenance(Origin.from_json(self.schema.metadata), self.config.settings_json()).dumps(),
            self.config.durable,
        )

    def _restore(self) -> None:
        """Continue a recovered dataset: same format, numbering, open files and running statistics."""
        info = read_info(self.root)
        check_same_format(self.root, info, self.schema.fps, self.features)
        t = self._target
        state = restore(self.root, self._data_schema, self._keys, t.chunks_size, t.video_limit, t.data_limit)
        self.tasks = dict(state.tasks)
        self._tasks_written = len(self.tasks)
        self.episode_rows = state.rows
        self.total_frames = state.total_frames
        self._runs.data = state.data_run
        self._runs.episodes = state.episodes_run
        for name, tail in state.videos.items():
            members = [VideoMember(ep, pos, frames, size) for ep, pos, frames, size in tail.members]
            self._runs.videos[name] = VideoGroup(tail.first, members)
        self._numeric_stats = state.numeric_stats
        self.image_stats.update(state.image_stats)
        self._next_index = self.total_episodes

    @property
    def total_episodes(self) -> int:
        return len(self.episode_rows)

    @property
    def uncommitted(self) -> int:  # `CommitsBehind`: handed to the committer, not committed (yet, or it failed)
        return 0 if self._committer is None else self._committer.unfinished

    @property
    def closed(self) -> bool:
        return self._closed

    def encoder_lag(self, index: int) -> dict[str, EncoderLag]:
        """Each camera's spilled frames and encoder lag in episode `index`, once this writer committed it."""
        return self._lags.get(index, {})

    # -- for callers that commit whole episodes (`commit_episode`, as `edit` does) -----------------------------
    def task_index(self, task: str) -> int:
        """The index of task string `task` in tasks.parquet, numbering it next if it is new (an episode's
        `task_indices` are these; a new one waits for the background commits, which read the tasks)."""
        if self._committer is not None and task not in self.tasks:
            self._committer.drain()
        return self.tasks.setdefault(task, len(self.tasks))

    def use_image_stats(self, image_stats: MappingOf[str, CameraStats]) -> None:
        """Write these per-camera accumulators as the dataset's image statistics at `close()` instead of the
        ones merged from the committed episodes (e.g. the exact histograms of exactly those episodes)."""
        self.image_stats = dict(image_stats)

    def override_stats(self, stats: MappingOf[str, Stats]) -> None:
        """Write these dataset-level statistics for their features at `close()` instead of the merged ones
        (e.g. exact histograms of a carried `dtype: image` feature)."""
        self._stats_override = dict(stats)

    # -- Sink API --------------------------------------------------------------------------------------------
    def begin_episode(self, start: EpisodeStart) -> None:
        if self._episode is not None:
            raise RuntimeError("begin_episode() while an episode is open")
        if self._committer is not None:
            self._committer.raise_failed()  # a background commit failed: nothing more is recorded
        self._episode = EpisodeBuffer(start, masks={name: MaskColumn() for name in self._masks})
        for name, worker in self._workers.items():
            shape = self.schema.cameras[name]
            # behind a committer the episodes before this one may not be placed yet: a staged name of its own
            path = self.pending_video(name) if self._committer is None else self._staged_video(name, self._next_index)
            worker.begin(path, shape.height, shape.width)

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
        ep.task_indices.append(self.task_index(frame.task))
        for key in self.schema.frame_extras:
            ep.extras.setdefault(key, []).append(frame.extras[key])
        for col in self.schema.frame_columns:
            ep.vectors.setdefault(col.key, []).append(frame.columns[col.key])
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
        if self._committer is not None and not self._committer.failed:
            self._committer.drain()  # the episodes handed over name their tasks too
        self._drop_unused_tasks()

    def _drop_unused_tasks(self) -> None:
        """Tasks first seen in a discarded episode must not reach tasks.parquet."""
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
        t0 = time.perf_counter()
        jobs = {name: worker.finish_later() for name, worker in self._workers.items()}
        self._episode = None
        c = self._committer
        index = self.total_episodes if c is None else self._next_index
        if c is None or index == 0:  # the first episode makes the dataset: committed before the next one starts
            record = self._finish_episode(ep, success, jobs, index, t0)
            self._next_index = self.total_episodes
            return record
        self._next_index += 1
        c.submit(partial(self._finish_episode, ep, success, jobs, index, t0))
        return EpisodeRecord(index, n, success if self.schema.has_success else None, ep.start.seed)

    def _finish_episode(
        self, ep: EpisodeBuffer, success: bool | None, jobs: dict[str, EncodeJob], index: int, t0: float
    ) -> EpisodeRecord:
        """Wait for the episode's videos, then commit it (in `end_episode`, or on the committer's thread)."""
        n = len(ep.states)
        try:
            encoded = wait_videos(self._workers, jobs, f"encoding episode {index}'s videos", self.root)
        except BaseException as exc:
            self._failed = self._failed or self._committer is not None or disk_errno(exc) is not None
            if self._committer is None:
                self._drop_unused_tasks()
            raise
        self._lags[index] = {name: job.lag for name, job in jobs.items()}
        if self.config.spill:  # a real-time recording: how the encoders kept up, in openral.episode_info
            ep.info = {**(ep.info or {}), CAPTURE: {name: job.lag.to_json() for name, job in jobs.items()}}
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
        log_commit(log, record.index, (t1 - t0) * 1000, (time.perf_counter() - t1) * 1000, self._workers)
        return record

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
            t, runs, rows = self._target, self._runs, self.episode_rows
            joins.maybe_consolidate(t, runs, rows, len(ep.states), self.config.staged_episodes)
            joins.rotate_videos(t, runs, rows, {name: enc.path.stat().st_size for name, enc in encoded.items()})
            saved = self._state()
            record = self._commit_episode(ep, len(ep.states), success, encoded)
            batch.commit()
        except OSError as exc:
            self._batch = None
            committed = self._fail(batch, saved, encoded, path, index)
            raise write_error(self.root, exc, f"committing episode {index}", committed) from exc
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
        if (journal is not None and journal.is_file()) or counted_episodes(self.root) > index:
            return True
        batch.discard()
        for name, enc in encoded.items():
            enc.path.unlink(missing_ok=True)
            if saved is not None:  # a video placed by this commit: no committed row names it
                group = saved.runs.videos[name]
                layout.video_path(self.root, self._keys[name], group.next_pos(self.config.chunks_size)).unlink(
                    missing_ok=True
                )
        if saved is not None:
            self._set_state(saved)
        return False

    def _state(self) -> _State:
        return _State(
            tasks=dict(self.tasks),
            tasks_written=self._tasks_written,
            total_frames=self.total_frames,
            episode_rows=list(self.episode_rows),
            runs=self._runs.copy(),
            numeric_stats=dict(self._numeric_stats),
            image_stats=copy.deepcopy(self.image_stats),
        )

    def _set_state(self, s: _State) -> None:
        used = {t for row in s.episode_rows for t in row["tasks"]}
        self.tasks = {t: i for t, i in s.tasks.items() if t in used}
        self._tasks_written = s.tasks_written
        self.total_frames = s.total_frames
        self.episode_rows = s.episode_rows
        self._runs = s.runs
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
        row = base_row(index, ep, success, self.tasks, self.total_frames)
        table = episode_table(self.schema, self.features, self._data_schema, index, ep, self.total_frames)
        ep_stats = column_stats(ep, table)
        for name, enc in encoded.items():
            self._place_video(name, index, enc.path, enc.frames, row)
            img = enc.stats.stats()
            ep_stats[self._keys[name]] = img
            merge_camera_stats(self.image_stats[name], enc.stats)
        for key, s in ep_stats.items():
            for stat, value in to_jsonable(s).items():
                row[f"stats/{key}/{stat}"] = value
        self._stage_data(table, row)
        pos = self._runs.episodes.next_pos(self.config.chunks_size)
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
            if self._committer is not None:  # the episodes handed over are committed first
                self._committer.close()
                self._failed = self._failed or self._committer.failed
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
        if self._committer is not None:
            self._committer.raise_failed()  # a commit behind the recording failed: the recording ends with it

    def _finish(self) -> None:
        """Join each camera's per-episode files and rewrite the metadata; a disk error stops it (every step of
        a join leaves each episode readable) and leaves the rest as it is."""
        doing = "finishing the dataset"
        try:
            t, runs, rows = self._target, self._runs, self.episode_rows
            if len(runs.episodes.positions) > 1 or len(runs.data.positions) > 1:
                doing = "joining the episodes' data files"
                joins.consolidate(t, runs, rows, rotate=False)
            for name in list(runs.videos):
                doing = f"joining the videos of camera {name}"
                joins.join_group(t, runs, rows, name)
            if self.total_episodes:
                doing = "writing the dataset's metadata"
                self._write_meta()
        except OSError as exc:
            self._failed = True
            raise write_error(self.root, exc, doing) from exc

    # -- files -----------------------------------------------------------------------------------------------
    def _stage_data(self, table: pa.Table, row: dict[str, Any]) -> None:
        """The episode's frames as a data file of its own (one row group, as lerobot writes an episode)."""
        pos = self._runs.data.next_pos(self.config.chunks_size)
        row["data/chunk_index"] = pos.chunk
        row["data/file_index"] = pos.file
        written = self._write(layout.data_path(self.root, pos), atomic.parquet_writer(table))
        self._runs.data.add(pos, written.stat().st_size, table.num_rows)

    def pending_video(self, name: str) -> Path:
        """Where camera `name`'s mp4 of the next episode is made; committing the episode moves it into place."""
        group = self._runs.videos[name]
        return atomic.tmp_name(layout.video_path(self.root, self._keys[name], group.next_pos(self.config.chunks_size)))

    def _staged_video(self, name: str, index: int) -> Path:
        return atomic.tmp_name(self.root / "videos" / self._keys[name] / f"episode-{index:06d}.mp4")

    def _place_video(self, name: str, episode: int, tmp: Path, frames: int, row: dict[str, Any]) -> None:
        key = self._keys[name]
        group = self._runs.videos[name]
        size = tmp.stat().st_size
        pos = group.next_pos(self.config.chunks_size)
        final = layout.video_path(self.root, key, pos)
        final.parent.mkdir(parents=True, exist_ok=True)
        atomic.move_into_place(tmp, final, self.config.durable)
        self._placed.append(final)
        group.members.append(VideoMember(episode, pos, frames, size))
        row[f"videos/{key}/chunk_index"] = pos.chunk
        row[f"videos/{key}/file_index"] = pos.file
        row[f"videos/{key}/from_timestamp"] = 0.0
        row[f"videos/{key}/to_timestamp"] = frames / self.schema.fps

    # -- metadata --------------------------------------------------------------------------------------------
    def _write(self, path: Path, writer: Callable[[Path], None]) -> Path:
        """Stage into the episode's batch while one is being committed, else replace atomically now; returns
        where the bytes are now (the staged file, or `path`)."""
        if self._batch is not None:
            self._batch.write_with(path, writer)
            return atomic.tmp_name(path)
        atomic.write_with(path, writer, self.config.durable)
        return path

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
        images = {self._keys[name]: acc.stats() for name, acc in self.image_stats.items()}
        ordered = dataset_stats(self.features, self._numeric_stats, images, self._stats_override)
        hist = {name: acc.to_json() for name, acc in self.image_stats.items()}
        self._write(self.root / layout.IMAGE_HIST_PATH, atomic.bytes_writer(json.dumps(hist).encode()))
        self._write(self.root / layout.STATS_PATH, atomic.bytes_writer(json.dumps(ordered, indent=4).encode()))
        info = json.dumps(self.info(), indent=4).encode()
        if batch is not None and episode is not None:
            pos = self._runs.episodes.next_pos(self.config.chunks_size)
            table = pa.Table.from_pylist([self.episode_rows[-1]], schema=self._episodes_schema)
            staged = self._write(layout.episodes_path(self.root, pos), atomic.parquet_writer(table, small=True))
            self._runs.episodes.add(pos, staged.stat().st_size, 1)
            files = [*batch.staged(), *((p, p) for p in self._placed)]
            delta = digests.delta_path(self.root, episode)
            self._write(delta, digests.delta_writer(self.root, files, {layout.INFO_PATH: info}))
            self._write(self.root / layout.INFO_PATH, atomic.bytes_writer(info))
            return
        self._write(self.root / layout.INFO_PATH, atomic.bytes_writer(info))
        digests.refresh(self.root, written, self.config.durable)

    def info(self) -> dict[str, Any]:
        totals = (self.total_episodes, self.total_frames, len(self.tasks))
        return dataset_info(self.schema, self.config, self.features, totals, bool(self._videos), self.episode_rows)
