"""Bring a dataset back to its last committed episode after a crash, losing nothing that was committed.

`meta/info.json` is the commit record: its totals say which episodes exist. After a SIGKILL the dataset may
hold, beside them:

* a commit journal (killed during an episode's renames): the renames are finished, the episode is kept;
* staged temporary files (``.NAME.tmp``: the episode in flight, or a commit that never reached its journal);
* rows beyond the totals (datasets written before the journal existed, or by other tools);
* video files no episode row names (an episode's mp4 placed before its commit, or per-episode files left
  after a join);
* after a join of the per-episode data and meta/episodes files cut short (`joins.consolidate`):
  episode rows repeated in a later episodes file, and data rows repeated in a file other than the one their
  episode's row names (both only in datasets we wrote);
* digest deltas of an episode that was never committed, and digests a cut-short join had not refreshed yet.

Every file recovery moves or rewrites gets its digests refreshed, so `doctor` afterwards reports only what
recovery could not explain.

Nothing is deleted: what recovery takes out goes to ``.openral/quarantine/<time>/`` with its relative path.
"""

from __future__ import annotations

import os
import shutil
import stat
from collections.abc import Callable, Iterator
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from openral_data.errors import DatasetError
from openral_data.formats import atomic
from openral_data.formats.lerobot_v3 import digests, layout
from openral_data.formats.lerobot_v3.reader import read_info
from openral_data.formats.lerobot_v3.video import concat_mp4, probe_frames
from openral_data.paths import contained

DATASET_DIRS = ("meta", "data", "videos")


class Quarantine:
    """One recovery's folder under .openral/quarantine/, created on first use."""

    def __init__(self, root: Path) -> None:
        self.root = root
        stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%S.%fZ")
        self.dir = root / layout.QUARANTINE_DIR / stamp
        self.touched: list[Path] = []  # every dataset file moved or rewritten, for the digests to follow

    def _dest(self, rel: str) -> Path:
        """Where `rel` goes; `.openral` and the quarantine folders must be real folders inside the dataset."""
        atomic.state_dir(self.root)
        base = self.root / layout.QUARANTINE_DIR
        for folder in (base, self.dir):
            if os.path.lexists(folder) and (folder.is_symlink() or not folder.is_dir()):
                raise DatasetError(f"{folder}: not a real folder; refusing to use it", code="dataset.unsafe")
        dest = contained(self.root, os.path.relpath(self.dir / rel, self.root), str(self.dir))
        dest.parent.mkdir(parents=True, exist_ok=True)
        return contained(self.root, os.path.relpath(dest, self.root), str(self.dir))

    def move(self, path: Path) -> Path:
        dest = self._dest(str(path.relative_to(self.root)))
        os.replace(path, dest)
        self.touched.append(path)
        return dest

    def keep_rows(self, path: Path, rows: pa.Table) -> Path:
        base = self._dest(f"{path.relative_to(self.root)}.removed-rows")
        dest, k = base.with_name(base.name + ".parquet"), 1
        while os.path.lexists(dest):  # never overwrite rows set aside earlier in this recovery
            k += 1
            dest = base.with_name(f"{base.name}-{k}.parquet")
        pq.write_table(rows, dest)
        return dest

    def keep_copy(self, path: Path) -> Path:
        """Keep the original of a file about to be replaced (the first copy wins: it is the original)."""
        dest = self._dest(str(path.relative_to(self.root)))
        if not os.path.lexists(dest):
            shutil.copy2(path, dest, follow_symlinks=False)
        return dest


def staged_files(root: Path) -> Iterator[Path]:
    """Temporary files of unfinished writes (atomic.tmp_name: ``.NAME.tmp``) inside the dataset folders."""
    for sub in DATASET_DIRS:
        base = root / sub
        if base.is_dir():
            yield from sorted(p for p in _walk(base) if p.name.startswith(".") and p.name.endswith(".tmp"))


def _walk(base: Path) -> Iterator[Path]:
    """Every regular file below `base`, never following a symlink (to a folder or a file) out of it."""
    if base.is_symlink():
        return
    for dirpath, _, files in os.walk(base, followlinks=False):
        for name in files:
            path = Path(dirpath) / name
            if stat.S_ISREG(os.lstat(path).st_mode):
                yield path


def referenced_videos(root: Path, rows: list[dict[str, Any]], info: dict[str, Any]) -> set[Path]:
    keys = [k for k, f in info.get("features", {}).items() if f.get("dtype") == "video"]
    out: set[Path] = set()
    for row in rows:
        for key in keys:
            chunk, file = row.get(f"videos/{key}/chunk_index"), row.get(f"videos/{key}/file_index")
            if chunk is not None and file is not None:
                out.add(layout.video_path(root, key, layout.FilePos(int(chunk), int(file))))
    return out


def finish_interrupted_commit(root: Path, durable: bool = True) -> list[str]:
    """Replay the commit journal of an episode commit killed during its renames (one line if it did)."""
    moved = atomic.replay_journal(root / layout.JOURNAL_PATH, durable)
    return [f"finished an interrupted episode commit ({moved} file(s) renamed into place)"] if moved else []


def quarantine_staged(root: Path, quarantine: Quarantine) -> int:
    """Move the temporary files of unfinished writes to the quarantine; returns how many there were."""
    staged = list(staged_files(root))
    for path in staged:
        quarantine.move(path)
    return len(staged)


def recover(root: Path, durable: bool = True) -> list[str]:
    """Finish or undo whatever a killed writer left; returns one line per action taken (empty: was clean)."""
    actions = finish_interrupted_commit(root, durable)
    quarantine = Quarantine(root)
    staged = quarantine_staged(root, quarantine)
    if staged:
        actions.append(f"moved {staged} staged file(s) of an unfinished episode to {quarantine.dir}")
    if not (root / layout.INFO_PATH).is_file():
        leftovers = [p for sub in DATASET_DIRS for p in _walk(root / sub)]
        for path in leftovers:
            quarantine.move(path)
        for sub in DATASET_DIRS:
            shutil.rmtree(root / sub, ignore_errors=True)
        if leftovers:
            actions.append(f"no committed episode: moved {len(leftovers)} file(s) to {quarantine.dir}")
        return actions
    info = read_info(root)
    ours = (root / layout.OPENRAL_PATH).is_file()
    if ours:
        actions += drop_repeated_episode_rows(root, quarantine, durable)
    actions += trim_to_totals(root, info, quarantine, durable)
    rows = episode_rows(root)
    if ours:
        actions += drop_repeated_data_rows(root, rows, quarantine, durable)
        actions += cut_unfinished_video_joins(root, rows, info, quarantine, durable)
    keep = referenced_videos(root, rows, info)
    orphans = [p for p in layout.video_files(root) if p not in keep]
    for path in orphans:
        quarantine.move(path)
    if orphans:
        actions.append(f"moved {len(orphans)} video file(s) no episode refers to to {quarantine.dir}")
    uncommitted = [p for k, p in digests.deltas(root) if k >= int(info.get("total_episodes", 0))]
    for path in uncommitted:
        quarantine.move(path)
    if quarantine.touched or uncommitted or (root / digests.REHASH_PATH).is_file():
        digests.refresh(root, quarantine.touched, durable)
    return actions


def cut_unfinished_video_joins(
    root: Path, rows: list[dict[str, Any]], info: dict[str, Any], quarantine: Quarantine, durable: bool = True
) -> list[str]:
    """A video join cut short before the metadata named it (the writer had listed its files, `digests.mark`):
    its first file already holds the whole group while the later rows still name their own files. That file is
    cut back (remuxed, no re-encode) to the frames its rows cover; the original goes to the quarantine."""
    listed = set(digests.pending(root))
    fps = int(info.get("fps", 0))
    keys = [k for k, f in info.get("features", {}).items() if f.get("dtype") == "video"]
    actions: list[str] = []
    for key in keys:
        covered: dict[Path, int] = {}
        for row in rows:
            if row.get(f"videos/{key}/chunk_index") is None or row.get(f"videos/{key}/to_timestamp") is None:
                continue
            path = layout.video_path(root, key, layout.row_pos(row, f"videos/{key}"))
            covered[path] = max(covered.get(path, 0), round(float(row[f"videos/{key}/to_timestamp"]) * fps))
        for path, frames in covered.items():
            if path not in listed or not path.is_file() or not 0 < frames < probe_frames(path):
                continue
            quarantine.keep_copy(path)
            atomic.write_with(path, _first_frames(path, frames, fps), durable)
            quarantine.touched.append(path)
            actions.append(
                f"{path.relative_to(root)}: an interrupted video join; cut back to the {frames} frame(s) its "
                f"episodes name (the original is in {quarantine.dir})"
            )
    return actions


def _first_frames(source: Path, frames: int, fps: int) -> Callable[[Path], None]:
    def write(tmp: Path) -> None:
        concat_mp4([(source, frames)], tmp, fps)

    return write


def drop_repeated_episode_rows(root: Path, quarantine: Quarantine, durable: bool = True) -> list[str]:
    """Rows of an episode already listed by an earlier episodes file (in file order, as lerobot reads them):
    what a join cut short left in the files it had not removed yet."""
    seen: set[int] = set()
    actions: list[str] = []
    for path in layout.episodes_files(root):
        indices = pq.read_table(path, columns=["episode_index"])["episode_index"].to_pylist()
        if seen:
            earlier = pa.array(sorted(seen), pa.int64())
            actions += _drop_rows(root, path, pc.field("episode_index").isin(earlier), quarantine, durable)
        seen.update(int(i) for i in indices)
    return actions


def drop_repeated_data_rows(
    root: Path, rows: list[dict[str, Any]], quarantine: Quarantine, durable: bool = True
) -> list[str]:
    """Data rows of an episode in a file other than the one its row names, when that file exists: copies a
    join cut short left behind (the joined file before the metadata named it, or the files it joined)."""
    owner: dict[int, Path] = {}
    for row in rows:
        if row.get("data/chunk_index") is None or row.get("data/file_index") is None:
            return []  # not ours to judge: rows that do not say where their frames are
        owner[int(row["episode_index"])] = layout.data_path(root, layout.row_pos(row, "data"))
    exists = {p: p.is_file() for p in set(owner.values())}
    actions: list[str] = []
    for path in layout.data_files(root):
        found = pc.unique(pq.read_table(path, columns=["episode_index"])["episode_index"]).to_pylist()
        elsewhere = [e for e in found if e in owner and owner[e] != path and exists[owner[e]]]
        if elsewhere:
            repeated = pc.field("episode_index").isin(pa.array(sorted(elsewhere), pa.int64()))
            actions += _drop_rows(root, path, repeated, quarantine, durable)
    return actions


def episode_rows(root: Path) -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = []
    for path in layout.episodes_files(root):
        rows += pq.read_table(path).to_pylist()
    return rows


def trim_to_totals(root: Path, info: dict[str, Any], quarantine: Quarantine, durable: bool = True) -> list[str]:
    """Take out rows beyond info.json's totals (episodes, frames, tasks); they are kept in the quarantine."""
    episodes = int(info.get("total_episodes", 0))
    frames = int(info.get("total_frames", 0))
    tasks = int(info.get("total_tasks", 0))
    actions: list[str] = []
    for path in layout.episodes_files(root):
        actions += _drop_rows(root, path, pc.field("episode_index") >= episodes, quarantine, durable)
    for path in layout.data_files(root):
        beyond = (pc.field("index") >= frames) | (pc.field("episode_index") >= episodes)
        actions += _drop_rows(root, path, beyond, quarantine, durable)
    tasks_path = root / layout.TASKS_PATH
    if tasks_path.is_file():
        actions += _drop_rows(root, tasks_path, pc.field("task_index") >= tasks, quarantine, durable)
    return actions


def _drop_rows(root: Path, path: Path, beyond: pc.Expression, quarantine: Quarantine, durable: bool) -> list[str]:
    table = pq.read_table(path)
    extra = table.filter(beyond)
    if extra.num_rows == 0:
        return []
    quarantine.keep_rows(path, extra)
    quarantine.touched.append(path)
    kept = table.filter(~beyond)
    rel = path.relative_to(root)
    if kept.num_rows == 0 and path.name != "tasks.parquet":
        path.unlink()
        if durable:
            atomic.fsync_dir(path.parent)
        return [f"{rel}: only uncommitted rows ({extra.num_rows}); moved them to {quarantine.dir}"]
    atomic.write_with(path, atomic.parquet_writer(kept), durable)
    return [f"{rel}: {extra.num_rows} row(s) beyond info.json's totals moved to {quarantine.dir}"]
