"""Where a dataset's quality table is kept, and whether it still holds.

The table is cached as parquet with a key in its schema metadata: a sha256 over the thresholds, the kind of data
(`thresholds.data_kind`, which adjusts them) and the (path,
size, mtime, inode) of every file `formats.lerobot_v3.digests` tracks (info.json, stats.json, tasks, the
episodes and data parquet files, the mp4s); the camera stride is kept beside it. Any write to the data changes
one of those, and the table is computed again; an unchanged dataset is never read twice. Stat rather than
content hashes: hashing would read every byte of every video to decide whether to read them.

Four files: the episodes' table (`quality.parquet`), the frames' (`quality_frames.parquet`), the sampled
camera frames' (`quality_camera_frames.parquet`) and the findings (`quality_findings.parquet`), all with the key.
Where: in `DATASET/.openral/` when the dataset has our `.openral/` folder and it is writable; else (a
lerobot-written dataset, a read-only folder, the Hub cache) in `$XDG_CACHE_HOME/openral-data/quality/<sha256 of
the dataset's resolved path>/` (`~/.cache` without XDG_CACHE_HOME): we never add files to a dataset we did not
write. The four are staged and renamed into place together (`formats.atomic.Batch`), the episodes' table last:
it is what says the others are current. One process computes them at a time (`computing`: a second `quality` of
the same dataset waits, then finds them current), as the staged files have fixed names.
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import pyarrow as pa

from openral_data import manifests
from openral_data.errors import DatasetError
from openral_data.formats import atomic
from openral_data.formats.lerobot_v3 import digests
from openral_data.formats.parquetfile import read_table

if TYPE_CHECKING:  # imported where used: `info` looks for a table (`cache_paths`) before anything else
    from openral_data.metrics.quality.thresholds import Thresholds

# of the measures: a change to how they are computed bumps it, so older tables are recomputed (2: image cameras;
# 3: findings, and frozen/jerky/clipped measured anew; 4: frame drops, repeated rows, degrees, idle edges, camera runs;
# 5: camera spans placed to the frame, camera_flipped's match; 6: joint limits and velocities from the robot manifest;
# 7: video_frames; 8: a still scene is no frozen or stalled camera, a slow encoder no frozen reading; 9: camera_lag;
# 10: a dimension moving by rounding residue holds still; 11: a teleport is one step alone, beyond a few counts;
# 12-13: frame_drop against 2 steps either side, position targets swapped, teleport's floor 0.05 and its order,
# velocity commands' lag limit; 14: 10-13 together; 15: camera_flipped on the mean picture, edges and motion;
# a flat top of a reading that holds most of the time is no clip; a state step within its position target's is
# no teleport; or (another branch's 15) frame drops the pictures show, `cuts`; 16: both 15s together; 17-19: frame
# drops on the position, 2+ dimensions jumping at once, the pictures read by window; 20: frame drops where a
# scripted motion starts, `leads`)
VERSION = 20
KEY = b"openral.quality.key"
LOCK = ".quality.lock"  # beside the tables: held while one process computes them (`computing`)
STRIDE = b"openral.quality.stride"


@dataclass(frozen=True)
class CachePaths:
    episodes: Path
    frames: Path
    camera_frames: Path
    findings: Path

    @staticmethod
    def inside(folder: Path) -> CachePaths:
        names = (
            "quality.parquet",
            "quality_frames.parquet",
            "quality_camera_frames.parquet",
            "quality_findings.parquet",
        )
        return CachePaths(*(folder / n for n in names))


def fingerprint(root: Path, th: Thresholds) -> str:
    from openral_data.metrics.quality.thresholds import data_kind

    files = sorted({p for pattern in (*digests.PATTERNS, *digests.SINGLE) for p in root.glob(pattern)})
    stats: list[list[object]] = []
    for path in files:
        try:
            st = path.stat()
        except OSError as exc:  # a dangling or looping symlink: its readers report it; here it is just a state
            stats.append([str(path.relative_to(root)), exc.errno])
            continue
        stats.append([str(path.relative_to(root)), st.st_size, st.st_mtime_ns, st.st_ino])
    text = json.dumps({"version": VERSION, "thresholds": th.as_json(), "kind": data_kind(root), "files": stats})
    return hashlib.sha256(text.encode()).hexdigest()


def user_cache_dir() -> Path:
    return manifests.cache_home() / "quality"


def cache_paths(root: Path) -> CachePaths:
    """Where `root`'s tables are kept (the module docstring says why there)."""
    ours = root / ".openral"
    if ours.is_dir() and not ours.is_symlink() and os.access(ours, os.W_OK):
        return CachePaths.inside(atomic.state_dir(root))
    return CachePaths.inside(user_cache_dir() / hashlib.sha256(str(root.resolve()).encode()).hexdigest()[:32])


@contextmanager
def computing(paths: CachePaths) -> Iterator[None]:
    """Exclusive while this process computes the tables at `paths`: a `quality` of the same dataset running
    meanwhile waits here (it would stage the same files). flock: the kernel drops it when its holder dies,
    SIGKILL included. The lock file is opened as a control file (no symlink, FIFO or device)."""
    folder = paths.episodes.parent
    folder.mkdir(parents=True, exist_ok=True)
    fd = atomic.open_control(folder / LOCK, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)


def metadata(key: str, stride: int) -> dict[bytes, bytes]:
    return {KEY: key.encode(), STRIDE: str(stride).encode()}


def current(schema: pa.Schema, key: str, stride: int | None) -> bool:
    """Whether a cached table's `schema` says it was computed under `key` (and at `stride`, when given)."""
    meta = schema.metadata or {}
    return meta.get(KEY) == key.encode() and (stride is None or meta.get(STRIDE) == str(stride).encode())


def load(path: Path, key: str, stride: int | None = None) -> pa.Table | None:
    """The cached table at `path` if it was computed under `key` (and at `stride`, when given); None if absent,
    stale or unreadable."""
    from openral_data.metrics.quality.table import SCHEMA  # (the measures' modules: not for `cache_paths`)

    if not path.is_file():
        return None
    try:
        table = read_table(path)
    except DatasetError:
        return None
    return table if current(table.schema, key, stride) and table.schema.equals(SCHEMA) else None


def stored_stride(table: pa.Table) -> int:
    return int((table.schema.metadata or {}).get(STRIDE, b"0"))
