"""`doctor`'s scan of what the frames mean, for datasets we did not write (v3 and v2.x alike): quaternions
flipping sign, angles wrapping by 2π, timestamps off the declared fps (`metrics.signals`), each a warning naming
the data file, the episode, the column and the frames (codes `findings.SCAN_*`). Only the numeric vector
features and `timestamp` are read, one data file at a time."""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa

from openral_data.doctor.findings import (
    SCAN_ANGLE_WRAP,
    SCAN_QUATERNION_FLIP,
    SCAN_TIMESTAMP_RATE,
    Finding,
    warning,
)
from openral_data.formats.parquetfile import read_schema, read_table
from openral_data.metrics.signals import Signal, angle_wraps, dimension_names, quaternion_flips, rate_mismatch

NUMERIC = ("float32", "float64")


def check_scan(root: Path, info: dict[str, Any], files: Iterable[Path]) -> list[Finding]:
    """The scan's warnings over every data file in `files` (absent ones are other checks' findings)."""
    features = {k: ft for k, ft in info["features"].items() if ft.get("dtype") in NUMERIC and k != "timestamp"}
    out: list[Finding] = []
    for path in files:
        if not path.is_file():
            continue
        names = read_schema(path).names
        if "episode_index" not in names:
            continue
        wanted = [k for k in features if k in names] + [c for c in ("timestamp",) if c in names]
        table = read_table(path, columns=["episode_index", *wanted])
        where = str(path.relative_to(root)) if path.is_relative_to(root) else str(path)
        for episode, part in _episodes(table):
            out += _scan_episode(part, features, float(info["fps"]), where, episode)
    return out


def _episodes(table: pa.Table) -> Iterable[tuple[int, pa.Table]]:
    """(episode_index, its rows) for each run of equal episode_index values, in file order."""
    ep = np.asarray(table.column("episode_index").to_numpy(zero_copy_only=False))
    if not len(ep):
        return
    starts = np.flatnonzero(np.concatenate([[True], ep[1:] != ep[:-1]]))
    for lo, hi in zip(starts, [*starts[1:], len(ep)], strict=True):
        yield int(ep[lo]), table.slice(int(lo), int(hi - lo))


def _scan_episode(
    part: pa.Table, features: dict[str, dict[str, Any]], fps: float, where: str, episode: int
) -> list[Finding]:
    out: list[Finding] = []
    for key, ft in features.items():
        if key not in part.column_names:
            continue
        values = _matrix(part.column(key))
        if values is None:
            continue
        names = dimension_names(key, ft, values.shape[1])
        for s in quaternion_flips(values, key, names):
            out.append(warning(SCAN_QUATERNION_FLIP, where, _say(episode, s, "quaternion sign flip")))
        for s in angle_wraps(values, key, names):
            out.append(warning(SCAN_ANGLE_WRAP, where, _say(episode, s, "angle wraps by 2π")))
    if "timestamp" in part.column_names:
        ts = np.asarray(part.column("timestamp").to_numpy(), dtype=np.float64)
        off = rate_mismatch(ts, fps)
        if off is not None:
            out.append(warning(SCAN_TIMESTAMP_RATE, where, _say(episode, off, "timestamps off the declared fps")))
    return out


def _matrix(column: pa.ChunkedArray) -> np.ndarray[Any, np.dtype[np.float64]] | None:
    """A (fixed-size) list column as frames x dims floats (a scalar column as one dim); None when it is not
    rectangular or not numbers."""
    arr = column.combine_chunks()
    n = len(arr)
    try:
        if pa.types.is_list(arr.type) or pa.types.is_large_list(arr.type) or pa.types.is_fixed_size_list(arr.type):
            if arr.null_count:
                return None
            flat = np.asarray(arr.flatten().to_numpy(zero_copy_only=False), dtype=np.float64)
            if n == 0 or len(flat) % n:
                return None
            values: np.ndarray[Any, np.dtype[np.float64]] = flat.reshape(n, -1)
        else:
            values = np.asarray(arr.to_numpy(zero_copy_only=False), dtype=np.float64)[:, None]
    except (ValueError, TypeError, pa.ArrowException):
        return None
    return values if n > 1 else None


def _say(episode: int, s: Signal, what: str) -> str:
    frames = ", ".join(str(f) for f in s.frames) + (f", … ({s.count} in all)" if s.count > len(s.frames) else "")
    detail = f"; {s.detail}" if s.detail else ""
    return f"episode {episode}: {', '.join(s.columns)}: {what} at frame(s) {frames}{detail}"
