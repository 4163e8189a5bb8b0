"""info.json, tasks.parquet, stats.json and the episodes table against lerobot 0.6.1's rules
(/work/shared/reference/lerobot-v3-format.md §2, §5-§7, §10)."""

from __future__ import annotations

import re
from collections import Counter

import numpy as np

from openral_data.doctor.check_missing import absent
from openral_data.doctor.findings import Finding, error, warning
from openral_data.doctor.inspect import DEFAULT_FEATURES, Dataset
from openral_data.errors import OpenralError
from openral_data.formats.jsonfile import load_json, read_json
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.missing import fetch_hint
from openral_data.formats.lerobot_v3.variants import task_column, task_is_index

INFO = layout.INFO_PATH
TASKS = layout.TASKS_PATH


def check_info(ds: Dataset) -> list[Finding]:
    out: list[Finding] = []
    version = str(ds.info.get("codebase_version"))
    m = re.fullmatch(r"v?(\d+)(\.\d+)*", version)
    if m is None:
        out.append(error("info.version", INFO, f"codebase_version {version!r} is not a version"))
    elif int(m.group(1)) < 3:
        out.append(error("info.version", INFO, f"codebase_version {version}: lerobot 0.6.1 loads v3 only"))
    missing = [k for k in DEFAULT_FEATURES if k not in ds.features]
    if missing:
        out.append(error("info.default_features", INFO, f"default feature(s) missing: {', '.join(missing)}"))
    for key, f in ds.features.items():
        if "/" in key:
            out.append(error("info.feature_name", INFO, f"feature {key!r}: '/' separates episodes-metadata columns"))
        if "dtype" not in f or "shape" not in f:
            out.append(error("info.feature", INFO, f"feature {key!r}: needs dtype and shape"))
    for key in ("chunks_size", "data_files_size_in_mb", "video_files_size_in_mb"):
        value = ds.info.get(key)
        if value is not None and (not isinstance(value, int) or value <= 0):
            out.append(error("info.sizes", INFO, f"{key} must be an integer > 0, got {value!r}"))
    return out


def check_provenance(ds: Dataset) -> list[Finding]:
    """Our `meta/openral.json` (absent in lerobot's datasets). Readers refuse one that is not a JSON object (an
    error) and read a block that is not one (`schema_metadata`, `config`, `edit`) as unknown (a warning)."""
    try:
        data = read_json(ds.root / layout.OPENRAL_PATH)
    except FileNotFoundError:
        return []
    except (OpenralError, OSError) as exc:
        return [error("openral.invalid", layout.OPENRAL_PATH, str(exc))]
    if not isinstance(data, dict):
        return [error("openral.invalid", layout.OPENRAL_PATH, f"expected a JSON object, got {type(data).__name__}")]
    blocks = ("schema_metadata", "config", "edit")
    bad = [k for k in blocks if data.get(k) is not None and not isinstance(data[k], dict)]
    return [warning("openral.invalid", layout.OPENRAL_PATH, f"{k}: not a JSON object; read as unknown") for k in bad]


def check_stats(ds: Dataset) -> list[Finding]:
    path = ds.root / layout.STATS_PATH
    if not path.is_file():
        hint = fetch_hint(ds.root, [layout.STATS_PATH])
        message = f"missing: lerobot's training normalisation needs it (a partial download? fetch it: {hint})"
        return [warning("stats.missing", layout.STATS_PATH, message)]
    try:
        stats = load_json(path)
    except (ValueError, OSError) as exc:
        return [error("stats.json", layout.STATS_PATH, f"invalid JSON: {exc}")]
    wanted = [k for k, f in ds.features.items() if f.get("dtype") != "string"]
    absent = [k for k in wanted if k not in stats]
    if absent:
        return [warning("stats.features", layout.STATS_PATH, f"no statistics for {', '.join(absent)}")]
    return []


def check_tasks(ds: Dataset) -> list[Finding]:
    out: list[Finding] = []
    total = ds.total("total_tasks")
    if ds.tasks is None:
        if total > 0 and not any(p.code == "tasks.unreadable" for p in ds.problems):
            out.append(error("tasks.missing", TASKS, f"missing while total_tasks is {total}"))
        return out
    names, column = ds.tasks.column_names, task_column(ds.tasks.schema)
    if "task_index" not in names or column is None:
        return [error("tasks.columns", TASKS, f"needs columns task_index and task, has {names}")]
    if not task_is_index(ds.tasks.schema):  # `task` as lerobot writes it, or older lerobot's unnamed index
        out.append(
            error(
                "tasks.pandas_index",
                TASKS,
                "the task is not the pandas index (lerobot then reports item['task'] as a number)",
                repairable=True,
            )
        )
    repeated = sorted(str(t) for t, n in Counter(ds.tasks[column].to_pylist()).items() if n > 1)
    if repeated:
        out.append(
            error(
                "tasks.duplicate",
                TASKS,
                f"task string(s) listed more than once: {repeated[:3]} (lerobot maps each task to one index)",
            )
        )
    order = [int(i) for i in ds.tasks["task_index"].to_pylist()]
    if order != list(range(len(order))):
        fixable = sorted(order) == list(range(len(order)))
        out.append(
            error(
                "tasks.order",
                TASKS,
                "rows are not in task_index order 0..n-1 (lerobot looks tasks up by row: wrong task strings)",
                repairable=fixable,
            )
        )
    return out


def episode_columns(ds: Dataset) -> list[str]:
    cols = ["episode_index", "tasks", "length", "data/chunk_index", "data/file_index"]
    cols += ["dataset_from_index", "dataset_to_index"]
    for key in ds.video_keys:
        cols += [f"videos/{key}/{c}" for c in ("chunk_index", "file_index", "from_timestamp", "to_timestamp")]
    return cols


def check_episodes(ds: Dataset) -> list[Finding]:
    where = "meta/episodes"
    total = ds.total("total_episodes")
    if ds.episodes is None:
        if total > 0 and not any(p.code == "episodes.unreadable" for p in ds.problems):
            return [error("episodes.missing", where, f"no episodes parquet while total_episodes is {total}")]
        return []
    missing = [c for c in episode_columns(ds) if c not in ds.episodes.column_names]
    if missing:
        return [error("episodes.columns", where, f"column(s) missing: {', '.join(missing)}")]
    out: list[Finding] = []
    idx = [int(i) for i in ds.episodes["episode_index"].to_pylist()]
    if idx != list(range(len(idx))):
        fixable = sorted(idx) == list(range(len(idx)))
        out.append(
            error(
                "episodes.order",
                where,
                "rows are not episode 0, 1, 2, … in file order (lerobot looks episodes up by row: "
                "items decode another episode's video)",
                repairable=fixable,
            )
        )
        return out
    lengths = np.asarray(ds.episodes["length"].to_pylist(), dtype=np.int64)
    if (lengths <= 0).any():
        out.append(error("episodes.length", where, "episode(s) with no frames"))
    start = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    lo = np.asarray(ds.episodes["dataset_from_index"].to_pylist(), dtype=np.int64)
    hi = np.asarray(ds.episodes["dataset_to_index"].to_pylist(), dtype=np.int64)
    bad = np.flatnonzero((lo != start) | (hi != start + lengths))
    if len(bad):
        out.append(
            error(
                "episodes.index_range",
                where,
                f"dataset_from/to_index do not follow the episode lengths (first: episode {int(bad[0])}; "
                "lerobot's delta windows use them)",
                repairable=True,
            )
        )
    return out


def check_totals(ds: Dataset) -> list[Finding]:
    """info.json's totals are what lerobot exposes; the files must hold exactly that much."""
    episodes = ds.episodes.num_rows if ds.episodes is not None else 0
    frames = ds.data.num_rows if ds.data is not None else 0
    tasks = ds.tasks.num_rows if ds.tasks is not None else 0
    said = (ds.total("total_episodes"), ds.total("total_frames"), ds.total("total_tasks"))
    if (episodes, frames, tasks) == said:
        return []
    if ds.episodes is None or ds.data is None or (absent(ds).data and (episodes, tasks) == (said[0], said[2])):
        return []  # reported as missing files (a partial download holds fewer frames than info.json counts)
    return [
        error(
            "info.totals",
            INFO,
            f"info.json counts {said[0]} episodes / {said[1]} frames / {said[2]} tasks, the files hold "
            f"{episodes} / {frames} / {tasks} (lerobot shows what info.json counts: "
            + ("frames are hidden)" if frames > said[1] else "it fails or falls back to the Hub)"),
            repairable=True,
        )
    ]
