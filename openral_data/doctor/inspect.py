"""Read a LeRobot v3 dataset (ours or lerobot's) the way lerobot 0.6.1's loader sees it, without lerobot.

Files are taken in the loader's order (sorted paths); the frame table is read only for the scalar columns
the checks need, so a large dataset costs one column scan.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import av
import pyarrow as pa
import pyarrow.parquet as pq

from openral_data.doctor.findings import Finding, error
from openral_data.errors import OpenralError
from openral_data.formats.jsonfile import load_json, parse_json
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.info import MAX_FEATURES
from openral_data.formats.lerobot_v3.missing import MissingFiles
from openral_data.formats.parquetfile import read_raw
from openral_data.paths import regular_file

DEFAULT_FEATURES = ("timestamp", "frame_index", "episode_index", "index", "task_index")
DATA_SCAN_COLUMNS = ("index", "episode_index", "frame_index", "timestamp", "task_index")
TOTALS = ("total_episodes", "total_frames", "total_tasks")
# what reading a damaged parquet file raises (pyarrow's errors are ArrowException, ValueError or OSError)
READ_ERRORS = (pa.ArrowException, OSError, ValueError, TypeError, KeyError, IndexError, OpenralError)
# what a check meets in a damaged file it did not expect (wrong types, absurd values, undecodable media)
DAMAGE = (
    ValueError,
    TypeError,
    KeyError,
    IndexError,
    ArithmeticError,
    MemoryError,
    OSError,
    pa.ArrowException,
    av.error.FFmpegError,
    OpenralError,
)


@dataclass
class Dataset:
    root: Path
    info: dict[str, Any]
    fps: int
    features: dict[str, dict[str, Any]]
    episode_files: list[Path]
    episodes: pa.Table | None  # every meta/episodes file concatenated in path order, stats columns dropped
    episode_file_rows: list[int]
    data_files: list[Path]
    data_schemas: list[pa.Schema]
    data: pa.Table | None  # DATA_SCAN_COLUMNS present in every file, concatenated in path order
    data_file_rows: list[int]
    tasks: pa.Table | None = None
    tasks_pandas: dict[str, Any] | None = None
    problems: list[Finding] = field(default_factory=list)  # unreadable files found while loading
    missing: MissingFiles | None = None  # the absent files the episodes name (`check_missing.absent`), once known

    @property
    def video_keys(self) -> list[str]:
        return [k for k, f in self.features.items() if f.get("dtype") == "video"]

    @property
    def column_features(self) -> list[str]:
        return [k for k, f in self.features.items() if f.get("dtype") != "video"]

    def rel(self, path: Path) -> str:
        return str(path.relative_to(self.root))

    def total(self, key: str) -> int:
        return int(self.info.get(key, 0) or 0)


def load(root: Path) -> tuple[Dataset | None, list[Finding]]:
    """The dataset, or None with the findings that make every further check meaningless. Never raises on a
    damaged file: what cannot be read becomes a finding."""
    path = root / layout.INFO_PATH
    if not root.is_dir():
        return None, [error("dataset.missing", str(root), "not a folder")]
    if not path.exists() and not path.is_symlink():
        return None, [error("info.missing", layout.INFO_PATH, "missing: lerobot falls back to a Hub download")]
    try:
        info = load_json(path)
    except ValueError as exc:  # bad or unbounded JSON: `load_json`
        return None, [error("info.json", layout.INFO_PATH, f"invalid JSON: {exc}")]
    except OSError as exc:  # a FIFO, device or folder (`load_json` refuses it before reading), an I/O error
        return None, [error("info.json", layout.INFO_PATH, f"cannot read: {exc.strerror or exc}")]
    if not isinstance(info, dict):
        return None, [error("info.json", layout.INFO_PATH, "not a JSON object")]
    missing = [k for k in ("codebase_version", "fps", "features") if k not in info]
    if missing:
        return None, [error("info.required", layout.INFO_PATH, f"required key(s) missing: {', '.join(missing)}")]
    fps = info["fps"]
    if not isinstance(fps, int) or isinstance(fps, bool) or fps <= 0:
        return None, [error("info.fps", layout.INFO_PATH, f"fps must be an integer > 0, got {fps!r}")]
    features = info["features"]
    if not isinstance(features, dict) or not all(isinstance(f, dict) for f in features.values()):
        return None, [error("info.features", layout.INFO_PATH, "features must map names to objects")]
    if len(features) > MAX_FEATURES:
        return None, [error("info.features", layout.INFO_PATH, f"more than {MAX_FEATURES} features")]
    for key in TOTALS:
        value = info.get(key, 0)
        if not isinstance(value, int) or isinstance(value, bool) or value < 0:
            return None, [error("info.types", layout.INFO_PATH, f"{key} must be an integer >= 0, got {value!r}")]
    ds = Dataset(root, info, fps, features, [], None, [], [], [], None, [])
    _load_tasks(ds)
    _load_episodes(ds)
    _load_data(ds)
    return ds, []


def read_parquet(path: Path, columns: list[str] | None = None) -> pa.Table:
    """A parquet file with its page checksums verified (a flipped byte in a page is an error, not a value)."""
    return read_raw(regular_file(path), columns, verify_pages=True)


def _unreadable(ds: Dataset, code: str, path: Path, exc: BaseException) -> None:
    ds.problems.append(error(code, ds.rel(path), f"unreadable parquet: {exc}"))


def _load_tasks(ds: Dataset) -> None:
    path = ds.root / layout.TASKS_PATH
    if not path.is_file():
        return
    try:
        tasks = read_parquet(path)
        raw = (tasks.schema.metadata or {}).get(b"pandas")
        pandas = parse_json(raw) if raw else None
    except READ_ERRORS as exc:
        _unreadable(ds, "tasks.unreadable", path, exc)
        return
    ds.tasks, ds.tasks_pandas = tasks, pandas if isinstance(pandas, dict) else None


def _load_episodes(ds: Dataset) -> None:
    ds.episode_files = layout.episodes_files(ds.root)
    tables = []
    for path in ds.episode_files:
        try:
            t = read_parquet(path)
        except READ_ERRORS as exc:
            _unreadable(ds, "episodes.unreadable", path, exc)
            return
        tables.append(t.select([c for c in t.column_names if not c.startswith("stats/")]))
        ds.episode_file_rows.append(t.num_rows)
    if not tables:
        return
    try:
        ds.episodes = pa.concat_tables(tables, promote_options="permissive")
    except READ_ERRORS as exc:
        ds.problems.append(error("episodes.unreadable", "meta/episodes", f"files do not share one schema: {exc}"))


def _load_data(ds: Dataset) -> None:
    """The scan columns of every data file; every page of every column is read once to verify its checksum."""
    ds.data_files = layout.data_files(ds.root)
    tables = []
    for path in ds.data_files:
        try:
            pf = pq.ParquetFile(regular_file(path), page_checksum_verification=True)
            schema = pf.schema_arrow
            cols = [c for c in DATA_SCAN_COLUMNS if c in schema.names]
            groups = [pf.read_row_group(i).select(cols) for i in range(pf.num_row_groups)]
            t = pa.concat_tables(groups) if groups else schema.empty_table().select(cols)
        except READ_ERRORS as exc:
            _unreadable(ds, "data.unreadable", path, exc)
            return
        ds.data_schemas.append(schema)
        ds.data_file_rows.append(t.num_rows)
        tables.append(t)
    common = [c for c in DATA_SCAN_COLUMNS if all(c in t.column_names for t in tables)]
    if not tables:
        return
    try:
        ds.data = pa.concat_tables([t.select(common).cast(_scan_schema(t.select(common))) for t in tables])
    except READ_ERRORS as exc:
        ds.problems.append(error("data.types", "data", f"index/frame columns of unexpected types: {exc}"))


def _scan_schema(t: pa.Table) -> pa.Schema:
    types = {"timestamp": pa.float64()}
    return pa.schema([(c, types.get(c, pa.int64())) for c in t.column_names])
