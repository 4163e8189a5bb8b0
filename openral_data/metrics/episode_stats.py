"""The **dimensions** summaries pooled from the per-episode statistics in `meta/episodes`, without a frame scan.

LeRobot v3 episodes tables carry `stats/<feature>/{min,max,mean,std,count,…}` per episode (our writer and
lerobot's). Pooled over episodes they give the dataset-level count/min/max/mean/std of every dimension exactly:
min and max of the minima and maxima; mean = Σ nᵢ·meanᵢ / N; variance = Σ nᵢ·(stdᵢ² + (meanᵢ − mean)²) / N (the
parallel-variance identity for population variances). This is O(episodes), independent of the frames.

They are used only when they are known to describe the frames on disk:

* **ours** (`.openral/digests.json` present): every episodes parquet hashes to its recorded sha256, and the data
  parquet files are exactly the recorded ones with their recorded sizes (a stat, no read). A mismatch anywhere
  falls back to the scan, whatever the options. A data file changed in place to other bytes of the same size is
  not seen here (hashing the frames would cost what the scan costs): `doctor` checks every byte.
* **foreign** (no digests, e.g. written by lerobot): nothing ties its stats to its frames (a stale converter
  output, an edited file), and lerobot computes them in float32 (the std as E[x²] − E[x]²): they are used only
  with `--trust-episode-stats`, and then to lerobot's float32 precision.

Either way they must also pass cheap consistency checks: every episode's `count` equals its `length`, the lengths
add up to the data files' rows (parquet footers), one value per dimension, min ≤ max and std ≥ 0, all finite.
Non-finite stats mean NaN/Inf frames (lerobot's and our min/max propagate NaN): the scan then summarises the
finite values. The reason for every fall-back is reported (`sources` table).
"""

from __future__ import annotations

from dataclasses import dataclass

import duckdb
import numpy as np
import numpy.typing as npt
import pyarrow as pa
import pyarrow.compute as pc

from openral_data.errors import DatasetError
from openral_data.formats.lerobot_v3 import digests
from openral_data.formats.parquetfile import read_table
from openral_data.metrics.scan import REWARD, DimStats, VectorScan, dimension_labels, vector_scan
from openral_data.metrics.sources import DatasetSource
from openral_data.metrics.views import files_sql, ident, query

EPISODE_STATS = "episode_stats"
FRAME_SCAN = "frame_scan"
BY_DIGESTS = "digests"
BY_TRUST = "--trust-episode-stats"
POOLED = ("min", "max", "mean", "std", "count")


@dataclass(frozen=True)
class DimensionSource:
    """Where a dataset's dimension summaries came from, and why."""

    dataset: str
    dimensions: str  # EPISODE_STATS | FRAME_SCAN
    verified_by: str | None  # BY_DIGESTS | BY_TRUST, None for the scan
    note: str


class _Unusable(Exception):
    """The episode statistics cannot stand for the frames; the message says why."""


def summarise(
    con: duckdb.DuckDBPyConnection, ds: DatasetSource, *, trust: bool = False, full_scan: bool = False
) -> tuple[VectorScan, DimensionSource]:
    """The dataset's dimension summaries, from its verified episode statistics when possible, else by the scan."""
    if full_scan:
        reason = "--full-scan"
    elif not ds.data_files:
        reason = "no data files"
    else:
        try:
            verified_by = _verify(ds, trust)
            scan = pooled_scan(con, ds)
        except _Unusable as exc:
            reason = str(exc)
        else:
            how = "sha256 of meta/episodes and data file sizes match .openral/digests.json"
            if verified_by == BY_TRUST:
                how = "trusted without digests; count, length and row checks passed"
            return scan, DimensionSource(ds.label, EPISODE_STATS, verified_by, how)
    return vector_scan(con, ds), DimensionSource(ds.label, FRAME_SCAN, None, reason)


def _verify(ds: DatasetSource, trust: bool) -> str:
    """BY_DIGESTS when our digests vouch for the episodes tables and data files, BY_TRUST for a foreign dataset
    with `trust`; else _Unusable with the reason."""
    try:
        stored = digests.read(ds.root)
    except DatasetError as exc:
        raise _Unusable(f"digests unreadable: {exc}") from None
    if stored is None:
        if trust:
            return BY_TRUST
        raise _Unusable(
            f"no {digests.DIGESTS_PATH} (not written by openral-data): --trust-episode-stats uses its stats"
        )
    for path in ds.episode_files:
        rel = str(path.relative_to(ds.root))
        entry = stored.get(rel)
        if entry is None:
            raise _Unusable(f"digest mismatch: {rel}: not in {digests.DIGESTS_PATH}")
        if digests.sha256_file(path) != entry["sha256"]:
            raise _Unusable(f"digest mismatch: {rel}: sha256 differs from {digests.DIGESTS_PATH}")
    on_disk = {str(p.relative_to(ds.root)): p for p in ds.data_files}
    recorded = {rel for rel in stored if rel.startswith("data/")}
    if set(on_disk) != recorded:
        extra = sorted(set(on_disk) ^ recorded)
        raise _Unusable(f"digest mismatch: data files differ from {digests.DIGESTS_PATH}: {', '.join(extra[:3])}")
    for rel, path in on_disk.items():
        if path.stat().st_size != stored[rel]["size"]:
            raise _Unusable(f"digest mismatch: {rel}: size differs from {digests.DIGESTS_PATH}")
    return BY_DIGESTS


def pooled_scan(con: duckdb.DuckDBPyConnection, ds: DatasetSource) -> VectorScan:
    """What `vector_scan` finds, pooled from the episodes tables (after the consistency checks)."""
    labels = dimension_labels(ds)
    features = list(dict.fromkeys(key for key, *_ in labels))
    reward = [REWARD] if REWARD in ds.data_columns else []
    wanted = ["length"] + [f"stats/{k}/{s}" for k in features for s in POOLED]
    missing = [c for c in wanted if c not in ds.episode_columns]
    if missing:
        raise _Unusable(f"no per-episode stats: meta/episodes has no column {missing[0]!r}")
    extra = [f"stats/{REWARD}/{s}" for s in ("min", "max")] if reward else []
    extra = extra if all(c in ds.episode_columns for c in extra) else []
    try:
        table = pa.concat_tables(
            [read_table(f, columns=wanted + extra) for f in ds.episode_files], promote_options="default"
        )
    except (DatasetError, pa.ArrowException) as exc:
        raise _Unusable(f"episode stats unreadable: {str(exc).splitlines()[0]}") from None
    lengths = _vectors(table, "length", None)
    rows = int(query(con, f"SELECT sum(num_rows) FROM parquet_file_metadata({files_sql(ds.data_files)})")[1][0][0])
    if int(lengths.sum()) != rows:
        raise _Unusable(f"episode lengths add up to {int(lengths.sum())} frames, the data files hold {rows} rows")
    keep = lengths[:, 0] > 0  # an episode without frames has nothing to pool (reported by the health checks)
    dims: list[DimStats] = []
    for key in features:
        names = [(i, name, expr) for k, i, name, expr in labels if k == key]
        d = len(names)
        count = _vectors(table, f"stats/{key}/count", 1)[keep, 0]
        if not np.array_equal(count, lengths[keep, 0]):
            raise _Unusable(f"stats/{key}/count differs from the episode length")
        mn, mx, mean, std = (_vectors(table, f"stats/{key}/{s}", d)[keep] for s in ("min", "max", "mean", "std"))
        if not all(np.isfinite(a).all() for a in (mn, mx, mean, std)):
            raise _Unusable(f"per-episode stats of {key} hold NaN/Inf (frames with NaN/Inf: the scan skips them)")
        if (mn > mx).any() or (std < 0).any():
            raise _Unusable(f"per-episode stats of {key} are inconsistent (min > max or std < 0)")
        total, mu, sigma = _pool(count, mean, std)
        low, high = mn.min(axis=0), mx.max(axis=0)
        for j, (i, name, expr) in enumerate(names):
            dims.append(
                DimStats(key, i, name, expr, total, float(low[j]), float(high[j]), float(mu[j]), float(sigma[j]))
            )
    non_finite = []
    if reward:
        finite = bool(extra) and all(np.isfinite(_vectors(table, c, 1)[keep]).all() for c in extra)
        if not finite:  # unknown: the health checks look at the reward column itself
            non_finite.append(ident(REWARD))
    return VectorScan(dims, non_finite)


def _pool(
    count: npt.NDArray[np.float64], mean: npt.NDArray[np.float64], std: npt.NDArray[np.float64]
) -> tuple[int, npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """Frames, mean and population std of the union of episodes with these counts (exact integers in float64
    up to 2⁵³), means and stds, each mean and variance a count-weighted sum (numpy's pairwise summation)."""
    n = count[:, None]
    total = float(n.sum())
    mu = (n * mean).sum(axis=0) / total
    var = (n * (std**2 + (mean - mu) ** 2)).sum(axis=0) / total
    return int(total), mu, np.sqrt(var)


def _vectors(table: pa.Table, column: str, width: int | None) -> npt.NDArray[np.float64]:
    """One episodes-table column as an (episodes, width) array; a scalar column (width None) as (episodes, 1)."""
    col = table.column(column)
    if col.null_count:
        raise _Unusable(f"{column}: empty for some episode")
    if width is None:
        return np.asarray(col.to_numpy(), dtype=np.float64).reshape(-1, 1)
    if not (pa.types.is_list(col.type) or pa.types.is_large_list(col.type) or pa.types.is_fixed_size_list(col.type)):
        raise _Unusable(f"{column}: not a list column ({col.type})")
    sizes = pc.list_value_length(col).to_numpy(zero_copy_only=False)
    if (sizes != width).any():
        raise _Unusable(f"{column}: not {width} value(s) per episode")
    values = pc.list_flatten(col)
    if values.null_count:
        raise _Unusable(f"{column}: empty values")
    return np.asarray(values.to_numpy(zero_copy_only=False), dtype=np.float64).reshape(-1, width)
