"""The frame table (data/*/*.parquet) against lerobot 0.6.1's rules (lerobot-v3-format.md §4, §10):
declared columns only, rows in index order with index == row position, per-episode frame_index 0..n-1 and
timestamp == frame_index / fps within the loader's 1e-4 s."""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from openral_data.doctor.check_missing import absent
from openral_data.doctor.findings import Finding, error
from openral_data.doctor.inspect import Dataset

TOLERANCE_S = 1e-4


def check_columns(ds: Dataset) -> list[Finding]:
    out: list[Finding] = []
    declared = ds.column_features
    for path, schema in zip(ds.data_files, ds.data_schemas, strict=False):  # up to an unreadable file
        extra = [c for c in schema.names if c not in ds.features]
        if extra:
            out.append(
                error(
                    "data.extra_column",
                    ds.rel(path),
                    f"column(s) not declared in info.json: {', '.join(extra)} (lerobot fails to load)",
                    repairable=True,
                )
            )
        missing = [c for c in declared if c not in schema.names]
        if missing:
            out.append(
                error(
                    "data.missing_column",
                    ds.rel(path),
                    f"declared feature(s) missing: {', '.join(missing)} (lerobot silently returns None)",
                )
            )
    return out


def _col(ds: Dataset, name: str) -> npt.NDArray[np.int64] | None:
    if ds.data is None or name not in ds.data.column_names:
        return None
    return np.asarray(ds.data[name].to_numpy(zero_copy_only=False))


def _frame_numbering(ep: npt.NDArray[np.int64], fi: npt.NDArray[np.int64]) -> tuple[list[int], bool]:
    """(episodes whose frame_index values are not 0..n-1 in any order, whether rows are out of order).

    Comparisons only (no arithmetic on the values), so a flipped high bit cannot overflow anything."""
    order = np.lexsort((fi, ep))
    se, sf = ep[order], fi[order]
    n = len(se)
    starts = np.flatnonzero(np.concatenate([[True], se[1:] != se[:-1]])) if n else np.zeros(0, dtype=np.int64)
    first = np.repeat(starts, np.diff(np.append(starts, n)))
    bad = sf != np.arange(n) - first
    broken = sorted({int(e) for e in se[bad]})
    unsorted = bool(n > 1 and ((ep[1:] < ep[:-1]) | ((ep[1:] == ep[:-1]) & (fi[1:] <= fi[:-1]))).any())
    return broken, unsorted


def check_rows(ds: Dataset) -> list[Finding]:
    gone = absent(ds).data  # not downloaded: `check_missing` says so; the rows there are not all the rows
    if ds.data is None:
        total = ds.total("total_frames")
        if total > 0 and not ds.data_files and not gone:
            return [error("data.missing", "data", f"no data parquet while total_frames is {total}")]
        return []
    where = "data"
    ep, fi, index = _col(ds, "episode_index"), _col(ds, "frame_index"), _col(ds, "index")
    if ep is None or fi is None or index is None:
        return []  # reported as missing columns
    out: list[Finding] = []
    n = len(ep)
    broken, unsorted = _frame_numbering(ep, fi)
    if broken:
        out.append(error("data.frame_index", where, f"frame_index is not 0..n-1 in episode(s) {broken[:5]}"))
        return out
    if unsorted:
        out.append(
            error(
                "data.order",
                where,
                "rows are not sorted by episode and frame (lerobot reads row i as item i)",
                repairable=True,
            )
        )
        return out
    if not gone and not np.array_equal(index, np.arange(n)):
        bad = int(np.flatnonzero(index != np.arange(n))[0])
        out.append(
            error(
                "data.index",
                where,
                f"index != row position from row {bad} (got {int(index[bad])}; lerobot's delta windows break)",
                repairable=True,
            )
        )
    ts = _col(ds, "timestamp")
    if ts is not None:
        off = np.abs(ts.astype(np.float64) - fi / ds.fps)
        if n and not (off <= TOLERANCE_S).all():
            bad = int(np.argmax(np.where(np.isnan(off), np.inf, off)))
            out.append(
                error(
                    "data.timestamp",
                    where,
                    f"timestamp != frame_index / fps (row {bad}: {float(ts[bad]):.6f} s, expected "
                    f"{fi[bad] / ds.fps:.6f} s; lerobot's video decoding fails beyond 1e-4 s)",
                    repairable=True,
                )
            )
    task = _col(ds, "task_index")
    if task is not None and ds.tasks is not None and n and (task.max() >= ds.tasks.num_rows or task.min() < 0):
        out.append(error("data.task_index", where, f"task_index outside 0..{ds.tasks.num_rows - 1}"))
    return out


def check_episode_rows(ds: Dataset) -> list[Finding]:
    """Each episodes-metadata row must match its frames: count, and position in the frame table (its rows are
    index dataset_from_index .. dataset_to_index - 1, each episode starting where the previous one ended)."""
    if ds.data is None or ds.episodes is None or "length" not in ds.episodes.column_names:
        return []
    ep, index = _col(ds, "episode_index"), _col(ds, "index")
    if ep is None:
        return []
    values, counts = np.unique(ep, return_counts=True)
    count = {int(e): int(c) for e, c in zip(values, counts, strict=True)}
    order = np.argsort(ep, kind="stable")
    firsts = np.searchsorted(ep[order], values)
    out: list[Finding] = []
    idx = [int(i) for i in ds.episodes["episode_index"].to_pylist()]
    lengths = [int(x) for x in ds.episodes["length"].to_pylist()]
    gone = {e for eps in absent(ds).data.values() for e in eps}  # their data is not downloaded: `check_missing`
    wrong = [e for e, n in zip(idx, lengths, strict=True) if count.get(e, 0) != n and e not in gone]
    limit = min(len(idx), ds.total("total_episodes"))
    wrong_committed = [e for e in wrong if e < limit]
    if wrong_committed:
        out.append(
            error(
                "data.episode_rows",
                "data",
                f"frame rows differ from the episodes' length in episode(s) {wrong_committed[:5]}",
            )
        )
    names = ds.episodes.column_names
    if index is None or "dataset_from_index" not in names or "dataset_to_index" not in names:
        return out
    lo = [int(x) for x in ds.episodes["dataset_from_index"].to_pylist()]
    hi = [int(x) for x in ds.episodes["dataset_to_index"].to_pylist()]
    off: list[int] = []
    previous_end = 0
    where = {int(e): int(f) for e, f in zip(values, firsts, strict=True)}
    for e, a, b in list(zip(idx, lo, hi, strict=True))[:limit]:
        rows = index[order[where.get(e, 0) : where.get(e, 0) + count.get(e, 0)]]
        if e in gone:
            previous_end = b
            continue
        if a != previous_end or not np.array_equal(rows, np.arange(a, a + len(rows))) or a + len(rows) != b:
            off.append(e)
        previous_end = b
    if off:
        out.append(
            error(
                "data.episode_range",
                "data",
                f"rows of episode(s) {off[:5]} are not index dataset_from_index..dataset_to_index - 1 following "
                "the previous episode (a dropped or moved row)",
            )
        )
    return out
