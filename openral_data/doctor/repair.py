"""`doctor --repair`: fix what can be fixed without guessing, under the dataset's writer lock.

Every rewrite is atomic (temp file, fsync, rename) and keeps the file it replaces — and any rows or files it
takes out — under ``.openral/quarantine/<time>/``: a repair never loses data. What it cannot fix safely
(missing columns or files, broken frame numbering, videos with missing frames) is reported, not touched.
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq

from openral_data.doctor.check import check
from openral_data.doctor.check_missing import absent
from openral_data.doctor.check_video import placements
from openral_data.doctor.findings import Finding
from openral_data.doctor.inspect import DAMAGE, Dataset, load
from openral_data.errors import DatasetError, DiskError, NotFound, disk_errno
from openral_data.formats import atomic
from openral_data.formats.lerobot_v3 import digests, layout
from openral_data.formats.lerobot_v3.layout import FilePos
from openral_data.formats.lerobot_v3.links import refuse_outside_links
from openral_data.formats.lerobot_v3.lock import DatasetLock
from openral_data.formats.lerobot_v3.recovery import Quarantine, finish_interrupted_commit, quarantine_staged
from openral_data.formats.lerobot_v3.tasks_table import tasks_writer
from openral_data.formats.lerobot_v3.variants import tasks_table
from openral_data.formats.lerobot_v3.video import count_packets

Rows = list[dict[str, Any]]


@dataclass(frozen=True)
class RepairResult:
    actions: list[str]  # what was done, one line each
    remaining: list[Finding]  # what the final check still finds
    quarantine: Path | None  # where replaced files and removed rows were kept (None: nothing was)
    refused: list[str] = field(default_factory=list)  # why nothing (more) was repaired, one line each


# a dataset with one of these is not rewritten: a repair must not act on what it cannot read
UNREADABLE = {
    "data.unreadable",
    "episodes.unreadable",
    "tasks.unreadable",
    "data.types",
    "check.failed",
    "data.frame_index",
    "video.unreadable",
    "info.json",
    "info.required",
    "info.fps",
    "info.features",
    "info.types",
}


def repair(root: Path) -> RepairResult:
    """Fix what is safely fixable; a dataset with files it cannot read is left as it is (`refused` says why).
    A disk that fails or is full meanwhile is one `DiskError` (the files replaced so far are in the quarantine)."""
    if not root.is_dir():  # nothing to repair, and nothing (not even the lock) may be created there
        raise NotFound(f"{root}: not a dataset folder")
    refuse_outside_links(root, "doctor --repair")  # plain doctor reports each one (`path.outside`)
    try:
        with DatasetLock(root, "openral-data doctor --repair"):
            return _repair(root)
    except Exception as exc:  # only a disk problem (its errno anywhere in the chain) is handled here
        errno = disk_errno(exc)
        if errno is None or isinstance(exc, DiskError):
            raise
        raise DiskError(root, errno, "repairing") from None


def _repair(root: Path) -> RepairResult:
    q = Quarantine(root)
    actions = _writer_leftovers(root, q)
    refused = _refusals(check(root, lock_held_by_us=True)) + _partial(root)
    steps = (_tasks, _episode_order, _data_columns, _data_rows, _totals, _index_range, _video_times)
    for step in steps if not refused else ():
        findings = {f.code: f for f in check(root, lock_held_by_us=True) if f.repairable}
        ds, _ = load(root)
        if ds is None:
            break
        try:
            actions += step(ds, findings, q)
        except DAMAGE as exc:
            if disk_errno(exc) is not None:
                raise  # not the dataset's fault: `repair` makes it one line
            refused.append(f"stopped in {step.__name__.strip('_')}: cannot read the dataset: {exc!r}")
            break
    ds, _ = load(root)
    if ds is not None and not refused:
        actions += _orphans(ds, {f.code: f for f in check(root, lock_held_by_us=True)}, q)
    _follow_digests(root, q)
    remaining = check(root, lock_held_by_us=True)
    return RepairResult(actions, remaining, q.dir if q.dir.exists() else None, refused)


def _refusals(findings: list[Finding]) -> list[str]:
    """One line per finding that makes rewriting the dataset unsafe (the files it names cannot be read)."""
    return [
        f"nothing rewritten: {f.where} cannot be read safely ({f.message}); restore it first"
        for f in findings
        if f.code in UNREADABLE
    ]


def _partial(root: Path) -> list[str]:
    """A partial download is not repaired: with data files absent, what the rest holds is not what info.json
    and the episodes count, and a repair would cut the dataset down to it (`check_missing`)."""
    ds, _ = load(root)
    if ds is None:
        return []
    try:
        gone = absent(ds)
    except DAMAGE:
        return []  # the checks report what cannot be read
    if not gone.data:
        return []
    return [
        f"nothing rewritten: data: {len(gone.data)} of {gone.named_data} file(s) not downloaded (a partial "
        f"download is not damage); fetch them first: {gone.fetch_hint()}"
    ]


def _follow_digests(root: Path, q: Quarantine) -> None:
    """The files this repair rewrote or took out (their originals are in the quarantine) get their digests
    updated: repair vouches for what it wrote. A changed file it did not touch keeps its finding."""
    if not q.dir.is_dir():
        return
    touched = [root / p.relative_to(q.dir) for p in q.dir.rglob("*") if p.is_file() and ".removed-rows" not in p.name]
    with contextlib.suppress(DatasetError):  # an unusable digests file stays reported by check as it is
        digests.refresh(root, touched)


def _writer_leftovers(root: Path, q: Quarantine) -> list[str]:
    out = finish_interrupted_commit(root)
    staged = quarantine_staged(root, q)
    if staged:
        out.append(f"moved {staged} temporary file(s) of an unfinished write to the quarantine")
    return out


# -- tasks ------------------------------------------------------------------------------------------------------
def _tasks(ds: Dataset, found: dict[str, Finding], q: Quarantine) -> list[str]:
    if ("tasks.pandas_index" not in found and "tasks.order" not in found) or ds.tasks is None:
        return []
    path = ds.root / layout.TASKS_PATH
    table = tasks_table(ds.tasks, path)
    names, indices = table["task"].to_pylist(), table["task_index"].to_pylist()
    tasks = {str(t): int(i) for t, i in zip(names, indices, strict=True)}
    q.keep_copy(path)
    atomic.write_with(path, tasks_writer(tasks))
    return [f"{layout.TASKS_PATH}: rewritten in task_index order with the task as the pandas index"]


# -- episodes table --------------------------------------------------------------------------------------------
def _read_episode_files(ds: Dataset) -> tuple[list[pa.Table], Rows]:
    tables = [pq.read_table(p) for p in ds.episode_files]
    rows: Rows = []
    for t in tables:
        rows += t.to_pylist()
    return tables, rows


def _write_episode_files(ds: Dataset, tables: list[pa.Table], rows: Rows, q: Quarantine) -> None:
    """Write `rows` back into the same files with the same row counts (fewer rows: trailing files emptied)."""
    start = 0
    for path, old in zip(ds.episode_files, tables, strict=True):
        part = rows[start : start + old.num_rows]
        start += old.num_rows
        q.keep_copy(path)
        if not part:
            path.unlink()
            continue
        pos = FilePos(int(path.parent.name[6:]), int(path.stem[5:]))
        for r in part:
            if "meta/episodes/chunk_index" in r:
                r["meta/episodes/chunk_index"], r["meta/episodes/file_index"] = pos.chunk, pos.file
        table = pa.Table.from_pylist(part, schema=old.schema)
        atomic.write_with(path, atomic.parquet_writer(table))


def _episode_order(ds: Dataset, found: dict[str, Finding], q: Quarantine) -> list[str]:
    if "episodes.order" not in found:
        return []
    tables, rows = _read_episode_files(ds)
    rows.sort(key=lambda r: int(r["episode_index"]))
    _write_episode_files(ds, tables, rows, q)
    return ["meta/episodes: rows put back in episode order"]


def _index_range(ds: Dataset, found: dict[str, Finding], q: Quarantine) -> list[str]:
    if "episodes.index_range" not in found:
        return []
    tables, rows = _read_episode_files(ds)
    start = 0
    for r in rows:
        r["dataset_from_index"], r["dataset_to_index"] = start, start + int(r["length"])
        start += int(r["length"])
    _write_episode_files(ds, tables, rows, q)
    return ["meta/episodes: dataset_from_index / dataset_to_index recomputed from the lengths"]


def _video_times(ds: Dataset, found: dict[str, Finding], q: Quarantine) -> list[str]:
    """Files whose packets are regular and add up to their episodes get from/to_timestamp recomputed."""
    codes = {"video.timestamps", "video.frames", "video.to_timestamp"}
    if not codes & set(found) or ds.episodes is None:
        return []
    tables, rows = _read_episode_files(ds)
    fixed: list[str] = []
    for key in ds.video_keys:
        for path, eps in placements(ds, key).items():
            if not path.is_file():
                continue
            times = count_packets(path)
            if len(times) != sum(p.length for p in eps):
                continue
            if any(abs(t - k / ds.fps) > 1e-4 for k, t in enumerate(times)):
                continue
            offset = 0
            changed = False
            for p in eps:
                r = rows[p.episode]
                want = (offset / ds.fps, (offset + p.length) / ds.fps)
                have = (r[f"videos/{key}/from_timestamp"], r[f"videos/{key}/to_timestamp"])
                if have != want:
                    r[f"videos/{key}/from_timestamp"], r[f"videos/{key}/to_timestamp"] = want
                    changed = True
                offset += p.length
            if changed:
                fixed.append(ds.rel(path))
    if fixed:
        _write_episode_files(ds, tables, rows, q)
        return [f"meta/episodes: from/to_timestamp recomputed from the frames of {', '.join(fixed[:3])}"]
    return []


# -- frame table -----------------------------------------------------------------------------------------------
def _rewrite_data(ds: Dataset, q: Quarantine, fn: Callable[[pa.Table, int, Path], pa.Table]) -> None:
    """Apply `fn(table, first_row_position, path)` to every data file in path order, keeping the originals."""
    start = 0
    for path in ds.data_files:
        table = pq.read_table(path)
        new = fn(table, start, path)
        start += new.num_rows
        if new.equals(table):
            continue
        q.keep_copy(path)
        atomic.write_with(path, atomic.parquet_writer(new))


def _data_columns(ds: Dataset, found: dict[str, Finding], q: Quarantine) -> list[str]:
    if "data.extra_column" not in found:
        return []
    keep = set(ds.features)
    _rewrite_data(ds, q, lambda t, _start, _path: t.select([c for c in t.column_names if c in keep]))
    return ["data: columns not declared in info.json moved out (the original files are in the quarantine)"]


def _data_rows(ds: Dataset, found: dict[str, Finding], q: Quarantine) -> list[str]:
    wanted = {"data.order", "data.index", "data.timestamp"} & set(found)
    if not wanted:
        return []
    fps = ds.fps

    def fix(t: pa.Table, start: int, _path: Path) -> pa.Table:
        if "data.order" in wanted:
            t = t.sort_by([("episode_index", "ascending"), ("frame_index", "ascending")])
        cols = {name: t[name] for name in t.column_names}
        if "index" in cols:
            cols["index"] = pa.chunked_array([pa.array(np.arange(start, start + t.num_rows), cols["index"].type)])
        if "data.timestamp" in wanted and "timestamp" in cols and "frame_index" in cols:
            fi = np.asarray(t["frame_index"].to_numpy(), dtype=np.float64)
            cols["timestamp"] = pa.chunked_array([pa.array(fi / fps, pa.float64()).cast(cols["timestamp"].type)])
        return pa.Table.from_pydict(cols, schema=t.schema)

    _rewrite_data(ds, q, fix)
    return [f"data: {', '.join(sorted(wanted))} repaired (rows sorted by episode/frame, index = row position)"]


def _totals(ds: Dataset, found: dict[str, Finding], q: Quarantine) -> list[str]:
    """Make info.json count the complete episodes the files hold; rows of an incomplete one are set aside."""
    if "info.totals" not in found or ds.episodes is None or ds.data is None:
        return []
    ep = np.asarray(ds.data["episode_index"].to_numpy(zero_copy_only=False))
    counts = np.bincount(ep[ep >= 0]) if len(ep) else np.zeros(0, dtype=np.int64)
    idx = [int(i) for i in ds.episodes["episode_index"].to_pylist()]
    lengths = [int(x) for x in ds.episodes["length"].to_pylist()]
    complete = 0
    for pos, (e, n) in enumerate(zip(idx, lengths, strict=True)):
        if e != pos or e >= len(counts) or counts[e] != n:
            break
        complete += 1
    actions: list[str] = []
    if complete < len(idx):
        tables, rows = _read_episode_files(ds)
        q.keep_rows(ds.root / "meta/episodes/set-aside", pa.Table.from_pylist(rows[complete:]))
        _write_episode_files(ds, tables, rows[:complete], q)
        actions.append(f"meta/episodes: {len(idx) - complete} incomplete episode row(s) set aside")
    if len(ep) and ep.max(initial=-1) >= complete:

        def drop(t: pa.Table, _start: int, path: Path) -> pa.Table:
            beyond = pc.greater_equal(t["episode_index"], complete)
            if pc.any(beyond).as_py():
                q.keep_rows(path, t.filter(beyond))
            return t.filter(pc.invert(beyond))

        _rewrite_data(ds, q, drop)
        actions.append(f"data: frame rows of episodes >= {complete} set aside")
    info = dict(ds.info)
    frames = sum(lengths[:complete])
    before = (info.get("total_episodes"), info.get("total_frames"), info.get("total_tasks"))
    info["total_episodes"], info["total_frames"] = complete, frames
    info["total_tasks"] = ds.tasks.num_rows if ds.tasks is not None else 0
    if "splits" in info:
        info["splits"] = {"train": f"0:{complete}"}
    q.keep_copy(ds.root / layout.INFO_PATH)
    atomic.write_bytes(ds.root / layout.INFO_PATH, json.dumps(info, indent=4).encode())
    after = (complete, frames, info["total_tasks"])
    actions.append(f"{layout.INFO_PATH}: totals (episodes, frames, tasks) {before} -> {after}")
    return actions


def _orphans(ds: Dataset, found: dict[str, Finding], q: Quarantine) -> list[str]:
    if "video.orphan" not in found:
        return []
    from openral_data.doctor.check_video import orphan_videos

    orphans = orphan_videos(ds)
    for path in orphans:
        q.move(path)
    return [f"videos: {len(orphans)} mp4 file(s) no episode refers to moved to the quarantine"]
