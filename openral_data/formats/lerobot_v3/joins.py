"""Joining a writer's per-episode files into lerobot's rotated layout, each step leaving every episode readable.

A committed episode's frames and meta/episodes row sit in files of their own (`Runs.data`, `Runs.episodes`) and
its mp4 of each camera likewise (`Runs.videos`) until a join puts them into the first file of their run: the
data and episodes files by `consolidate` (one row group per episode), a camera's mp4s by `join_group` (remuxed,
never re-encoded). `LeRobotV3Writer` calls these before an episode's commit when a file fills up or too many
episodes wait (`maybe_consolidate`, `rotate_videos`), and at `close()`. A join is a commit of its own: the files
it replaces are listed first (`digests.mark`), so a crash in between leaves recovery what to re-hash.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pyarrow as pa

from openral_data.formats import atomic
from openral_data.formats.lerobot_v3 import digests, layout
from openral_data.formats.lerobot_v3.layout import FilePos, FileRun
from openral_data.formats.lerobot_v3.video import concat_mp4


@dataclass(frozen=True)
class Target:
    """The dataset the joins write: its folder, camera keys, Arrow schemas and file limits."""

    root: Path
    fps: int
    keys: dict[str, str]  # camera name -> its feature key (its video files' folder)
    data_schema: pa.Schema
    episodes_schema: pa.Schema
    chunks_size: int
    durable: bool
    data_limit: int  # bytes of a data (and meta/episodes) file
    video_limit: int  # bytes of a video file


@dataclass
class VideoMember:
    episode: int
    pos: FilePos
    frames: int
    size: int


@dataclass
class VideoGroup:
    """Episodes of one camera that will share one mp4 (each in its own file until joined)."""

    first: FilePos
    members: list[VideoMember] = field(default_factory=list)

    @property
    def size(self) -> int:
        return sum(m.size for m in self.members)

    def next_pos(self, chunks_size: int) -> FilePos:
        return self.members[-1].pos.next(chunks_size) if self.members else self.first


@dataclass
class Runs:
    """Where the episodes not joined yet sit: the data and meta/episodes runs, and each camera's video group."""

    data: FileRun
    episodes: FileRun
    videos: dict[str, VideoGroup]

    def copy(self) -> Runs:
        videos = {n: VideoGroup(g.first, list(g.members)) for n, g in self.videos.items()}
        return Runs(self.data.copy(), self.episodes.copy(), videos)


def maybe_consolidate(t: Target, runs: Runs, rows: list[dict[str, Any]], frames: int, staged_episodes: int) -> None:
    """Before an episode's commit: join the runs when the data file would outgrow its size limit with this
    episode (the episode then starts the next file), or when `staged_episodes` episodes wait in files of
    their own. The join is a commit of its own."""
    data = runs.data
    if data.positions and data.size + data.size / max(data.total_rows, 1) * frames >= t.data_limit:
        consolidate(t, runs, rows, rotate=True)
    elif len(runs.episodes.positions) > staged_episodes:
        consolidate(t, runs, rows, rotate=False)


def consolidate(t: Target, runs: Runs, rows: list[dict[str, Any]], rotate: bool) -> None:
    """Join the data run into its first file and the episodes run into its first file, `rows` (every
    episode's meta/episodes row) re-pointed.

    Every step leaves a dataset lerobot loads exactly: the joined data file replaces the first (its rows
    now also sit, the same, in the later files, which sort after it: rows beyond info.json's total), then
    the joined episodes file (the later files' rows likewise trail), then the later files go. The files
    are listed first (`digests.mark`), so a crash in between leaves recovery what to re-hash.
    `rotate`: the data file is full; the next episode starts the next file.
    """
    data, eps = runs.data, runs.episodes
    dest_data = layout.data_path(t.root, data.first)
    dest_eps = layout.episodes_path(t.root, eps.first)
    later = [layout.data_path(t.root, p) for p in data.positions[1:]]
    later += [layout.episodes_path(t.root, p) for p in eps.positions[1:]]
    changed = [*([dest_data] if data.positions else []), *([dest_eps] if eps.positions else []), *later]
    digests.mark(t.root, changed, t.durable)
    if len(data.positions) > 1:
        sources = [layout.data_path(t.root, p) for p in data.positions]
        atomic.write_with(dest_data, atomic.concat_parquet_writer(sources, t.data_schema), t.durable)
    moved_data, moved_eps = set(data.positions[1:]), set(eps.positions[1:])
    tail = rows[len(rows) - eps.total_rows :]  # the rows in the episodes run
    repointed = False
    for row in tail:
        if layout.row_pos(row, "data") in moved_data:
            row["data/chunk_index"], row["data/file_index"] = data.first.chunk, data.first.file
            repointed = True
        if layout.row_pos(row, "meta/episodes") in moved_eps:
            row["meta/episodes/chunk_index"], row["meta/episodes/file_index"] = eps.first.chunk, eps.first.file
    if len(eps.positions) > 1 or repointed:  # (one episodes file whose rows now name the joined data file)
        table = pa.Table.from_pylist(tail, schema=t.episodes_schema)
        atomic.write_with(dest_eps, atomic.parquet_writer(table), t.durable)
    for path in later:
        path.unlink(missing_ok=True)
    if t.durable:
        for parent in dict.fromkeys(p.parent for p in later):
            atomic.fsync_dir(parent)
    digests.refresh(t.root, changed, t.durable)
    if rotate:
        runs.data = FileRun(data.first.next(t.chunks_size))
    elif data.positions:
        runs.data = FileRun(data.first, [data.first], [dest_data.stat().st_size], [data.total_rows])
    if eps.positions:
        eps_size = dest_eps.stat().st_size
        if eps_size >= t.data_limit:
            runs.episodes = FileRun(eps.first.next(t.chunks_size))
        else:
            runs.episodes = FileRun(eps.first, [eps.first], [eps_size], [eps.total_rows])


def rotate_videos(t: Target, runs: Runs, rows: list[dict[str, Any]], sizes: dict[str, int]) -> None:
    """A camera whose file would outgrow its size limit with the next episode (`sizes`: its new mp4's bytes
    per camera): join its full group first (the episode then starts the next file). Done before the
    episode's commit: the join is a commit of its own."""
    for name, size in sizes.items():
        group = runs.videos[name]
        if group.members and group.size + size >= t.video_limit:
            if len(runs.episodes.positions) > 1:  # the join re-points rows: one episodes file to rewrite
                consolidate(t, runs, rows, rotate=False)
            join_group(t, runs, rows, name)


def join_group(t: Target, runs: Runs, rows: list[dict[str, Any]], name: str) -> None:
    """Join a camera's per-episode files into the group's first file, then point the episodes at it.

    Order keeps every episode readable at every instant: the first episode stays at timestamp 0 of the
    first file, the others keep their own files until the metadata no longer names them.
    """
    group = runs.videos[name]
    key = t.keys[name]
    if len(group.members) > 1:
        dest = layout.video_path(t.root, key, group.first)
        sources = [(layout.video_path(t.root, key, m.pos), m.frames) for m in group.members]
        touched = {layout.row_pos(rows[m.episode], "meta/episodes") for m in group.members}
        changed = [dest, *(layout.episodes_path(t.root, pos) for pos in touched), *(p for p, _ in sources[1:])]
        digests.mark(t.root, changed, t.durable)
        atomic.write_with(dest, lambda tmp: concat_mp4(sources, tmp, t.fps), t.durable)
        offset = 0
        for m in group.members:
            row = rows[m.episode]
            row[f"videos/{key}/chunk_index"] = group.first.chunk
            row[f"videos/{key}/file_index"] = group.first.file
            row[f"videos/{key}/from_timestamp"] = offset / t.fps
            offset += m.frames
            row[f"videos/{key}/to_timestamp"] = offset / t.fps
        write_episodes(t, rows, touched)
        for m in group.members[1:]:
            layout.video_path(t.root, key, m.pos).unlink(missing_ok=True)
        # the join replaced files outside a commit batch: their digests follow at once
        digests.refresh(t.root, changed, t.durable)
    start = group.first.next(t.chunks_size) if group.members else group.first
    runs.videos[name] = VideoGroup(start)


def write_episodes(t: Target, rows: list[dict[str, Any]], files: set[FilePos]) -> None:
    """Rewrite whole meta/episodes files now (outside a commit: a video join re-pointed their rows)."""
    for pos in sorted(files):
        kept = [
            r for r in rows if (r["meta/episodes/chunk_index"], r["meta/episodes/file_index"]) == (pos.chunk, pos.file)
        ]
        table = pa.Table.from_pylist(kept, schema=t.episodes_schema)
        atomic.write_with(layout.episodes_path(t.root, pos), atomic.parquet_writer(table), t.durable)
