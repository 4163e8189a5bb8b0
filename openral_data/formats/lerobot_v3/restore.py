"""What a resumed writer needs from the dataset it continues: counters, rows, open files, running stats.

The dataset must be recovered first (`recovery.recover`): then every episode row, data row and video file
on disk is committed, and the state rebuilt here is exactly what the writer held after its last episode.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from openral_data.errors import DatasetError, OutputExists
from openral_data.formats import atomic
from openral_data.formats.jsonfile import parse_json
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.depth import CameraStats, camera_stats_from_json
from openral_data.formats.lerobot_v3.layout import FilePos, FileRun
from openral_data.formats.lerobot_v3.reader import read_info, read_tasks_table
from openral_data.formats.lerobot_v3.recovery import episode_rows
from openral_data.formats.lerobot_v3.stats import STAT_KEYS, Stats, merge_numeric
from openral_data.formats.lerobot_v3.video import probe_frames


@dataclass
class VideoTail:
    """A camera's last group: episodes still in their own files (joined later), or where the next file goes."""

    first: FilePos
    members: list[tuple[int, FilePos, int, int]] = field(default_factory=list)  # episode, file, frames, bytes


@dataclass
class Restored:
    tasks: dict[str, int]
    rows: list[dict[str, Any]]
    total_frames: int
    data_run: FileRun
    episodes_run: FileRun
    videos: dict[str, VideoTail]  # camera name -> tail
    numeric_stats: dict[str, Stats]
    image_stats: dict[str, CameraStats]  # empty before the first episode: the writer keeps its fresh ones


def check_same_format(root: Path, info: dict[str, Any], fps: int, features: dict[str, dict[str, Any]]) -> None:
    """Refuse to continue a dataset whose fps, cameras, contracts or codec differ, naming the first field."""
    where = root / layout.INFO_PATH
    if int(info.get("fps", 0)) != fps:
        raise DatasetError(
            f"{where}: fps: the dataset has {info.get('fps')}, this recording {fps}", code="dataset.mismatch"
        )
    old = info.get("features", {})
    for key in sorted(set(old) | set(features)):
        if key not in old:
            raise DatasetError(
                f"{where}: features.{key}: not in the dataset, but this recording has it", code="dataset.mismatch"
            )
        if key not in features:
            raise DatasetError(
                f"{where}: features.{key}: in the dataset, but this recording does not have it", code="dataset.mismatch"
            )
        for part in ("dtype", "shape", "names"):
            if old[key].get(part) != features[key].get(part):
                raise DatasetError(
                    f"{where}: features.{key}.{part}: the dataset has {old[key].get(part)}, "
                    f"this recording {features[key].get(part)}",
                    code="dataset.mismatch",
                )
        a, b = old[key].get("info") or {}, features[key].get("info") or {}
        for part in sorted(set(a) | set(b)):
            if a.get(part) != b.get(part):
                raise DatasetError(
                    f"{where}: features.{key}.info.{part}: the dataset has {a.get(part)}, this recording {b.get(part)}",
                    code="dataset.mismatch",
                )


def restore(
    root: Path,
    data_schema: pa.Schema,
    camera_keys: dict[str, str],
    chunks_size: int,
    size_limit: int,
    data_size_limit: int,
) -> Restored:
    info = read_info(root)
    rows = episode_rows(root)
    if [int(r["episode_index"]) for r in rows] != list(range(int(info.get("total_episodes", 0)))):
        raise DatasetError(
            f"{root}: episode rows do not match info.json; run `openral-data doctor --repair` first",
            code="dataset.interrupted",
        )
    tasks: dict[str, int] = {}
    if rows:
        table = read_tasks_table(root)  # any layout lerobot reads (older lerobot's unnamed index too)
        names, indices = table["task"].to_pylist(), table["task_index"].to_pylist()
        tasks = {str(t): int(i) for t, i in zip(names, indices, strict=True)}
    numeric: dict[str, Stats] = {}
    for row in rows:
        for key in data_schema.names:
            s = {stat: np.asarray(row[f"stats/{key}/{stat}"]) for stat in STAT_KEYS}
            numeric[key] = merge_numeric(numeric.get(key), s)
    data_run = _file_run(rows, "data", lambda p: layout.data_path(root, p), chunks_size, data_size_limit, True)
    # a join re-points the rows of the episodes whose data it moves, which it finds in the episodes run: that run
    # holds every episode staged in the data run, even one whose meta/episodes file alone reaches the limit
    staged = set(data_run.positions[1:])
    needed = [layout.row_pos(r, "meta/episodes") for r in rows if layout.row_pos(r, "data") in staged]
    return Restored(
        tasks=tasks,
        rows=rows,
        total_frames=sum(int(r["length"]) for r in rows),
        data_run=data_run,
        episodes_run=_file_run(
            rows,
            "meta/episodes",
            lambda p: layout.episodes_path(root, p),
            chunks_size,
            data_size_limit,
            False,
            keep_from=min(needed, default=None),
        ),
        videos={name: _video_tail(root, key, rows, chunks_size, size_limit) for name, key in camera_keys.items()},
        numeric_stats=numeric,
        image_stats=_image_stats(root, list(camera_keys), bool(rows)),
    )


def _file_run(
    rows: list[dict[str, Any]],
    prefix: str,
    path_of: Callable[[FilePos], Path],
    chunks_size: int,
    size_limit: int,
    frames: bool,
    keep_from: FilePos | None = None,
) -> FileRun:
    """The trailing consecutive files (data or meta/episodes) whose bytes stay below the size limit: the run
    the writer goes on joining (episodes still in files of their own, after the one they join into). The files
    from `keep_from` on are in it whatever their size."""
    counts: dict[FilePos, int] = {}
    for r in rows:
        pos = layout.row_pos(r, prefix)
        counts[pos] = counts.get(pos, 0) + (int(r["length"]) if frames else 1)
    order = list(counts)
    run = FileRun(order[-1].next(chunks_size) if order else FilePos())
    total = 0
    for i in range(len(order) - 1, -1, -1):
        pos, size = order[i], path_of(order[i]).stat().st_size
        follows = i == len(order) - 1 or pos.next(chunks_size) == order[i + 1]
        if not follows or (total + size >= size_limit and (keep_from is None or pos < keep_from)):
            break
        total += size
        run.first = pos
        run.positions.insert(0, pos)
        run.sizes.insert(0, size)
        run.rows.insert(0, counts[pos])
    return run


def _video_tail(root: Path, key: str, rows: list[dict[str, Any]], chunks_size: int, size_limit: int) -> VideoTail:
    """The trailing episodes that sit alone in consecutive files (a group not yet joined) become the group."""

    def pos(r: dict[str, Any]) -> FilePos:
        return layout.row_pos(r, f"videos/{key}")

    users: dict[FilePos, int] = {}
    for r in rows:
        users[pos(r)] = users.get(pos(r), 0) + 1
    files = layout.video_files(root, key)
    on_disk = [FilePos(int(p.parent.name[6:]), int(p.stem[5:])) for p in files]
    last = max([*users, *on_disk], default=None)
    members: list[tuple[int, FilePos, int, int]] = []
    for r in reversed(rows):
        p = pos(r)
        alone = users[p] == 1 and float(r[f"videos/{key}/from_timestamp"]) == 0.0
        follows = not members or p.next(chunks_size) == members[0][1]
        path = layout.video_path(root, key, p)
        # `>=`: a join cut short by a disk error wrote the group into its first file before the metadata named
        # it; that file starts with its own episode, and joining the group again takes only those frames
        if not (alone and follows and path.is_file() and probe_frames(path) >= int(r["length"])):
            break
        members.insert(0, (int(r["episode_index"]), p, int(r["length"]), path.stat().st_size))
    if members and sum(m[3] for m in members) < size_limit:
        return VideoTail(first=members[0][1], members=members)
    return VideoTail(first=last.next(chunks_size) if last is not None else FilePos())


def _image_stats(root: Path, names: list[str], has_rows: bool) -> dict[str, CameraStats]:
    if not names or not has_rows:
        return {}
    path = root / layout.IMAGE_HIST_PATH
    try:
        saved = parse_json(atomic.read_control(path))  # a control file: no symlink, no FIFO, bounded
    except FileNotFoundError:
        raise DatasetError(
            f"{path}: missing: cannot continue this dataset's camera statistics exactly", code="dataset.incomplete"
        ) from None
    except ValueError as exc:
        raise DatasetError(f"{path}: invalid JSON: {exc}", code="dataset.invalid") from None
    if not isinstance(saved, dict):
        raise DatasetError(f"{path}: not a JSON object", code="dataset.invalid")
    accs: dict[str, CameraStats] = {}
    for name in names:
        if name not in saved:
            raise DatasetError(f"{path}: {name}: no histogram for this camera", code="dataset.incomplete")
        accs[name] = camera_stats_from_json(saved[name])
    return accs


def claim_root(root: Path, resume: bool) -> bool:
    """Create `root` for a new dataset (refusing one that holds anything but openral-data's own bookkeeping
    folder, the lock of the recording taking it), or take it to continue; returns whether it was created."""
    if not resume and root.exists() and (not root.is_dir() or any(p.name != layout.STATE_DIR for p in root.iterdir())):
        raise OutputExists(f"{root}: output exists and is not empty; refusing to overwrite it")
    created = not root.exists()
    root.mkdir(parents=True, exist_ok=True)
    return created
