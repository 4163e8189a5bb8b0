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


def summarise(
    con: duckdb.DuckDBPyConnection, ds: DatasetSource, *, trust: bool = False, full_scan: bool = False
) -> tuple[VectorScan, DimensionSource]:
    """The dataset's dimension summaries, from its verified episode statistics when possible, else by the scan."""
    if full_scan:
        reason = "--full-scan"
    elif not ds.data_files:
        reason = "no data files"
    else:
        verified_by, reason = _verify(ds, trust)
        pooled = pooled_scan(con, ds) if verified_by else reason
        if isinstance(pooled, VectorScan):
            how = "sha256 of meta/episodes and data file sizes match .openral/digests.json"
            if verified_by == BY_TRUST:
                how = "trusted without digests; count, length and row checks passed"
            return pooled, DimensionSource(ds.label, EPISODE_STATS, verified_by, how)
        reason = pooled
    return vector_scan(con, ds), DimensionSource(ds.label, FRAME_SCAN, None, reason)


def _verify(ds: DatasetSource, trust: bool) -> tuple[str | None, str]:
    """(BY_DIGESTS, "") when our digests vouch for the episodes tables and data files, (BY_TRUST, "") for a foreign
    dataset with `trust`; else (None, the reason)."""
    try:
        stored = digests.read(ds.root)
    except DatasetError as exc:
        return None, f"digests unreadable: {exc}"
    if stored is None:
        if trust:
            return BY_TRUST, ""
        return None, f"no {digests.DIGESTS_PATH} (not written by openral-data): --trust-episode-stats uses its stats"
    for path in ds.episode_files:
        rel = str(path.relative_to(ds.root))
        entry = stored.get(rel)
        if entry is None:
            return None, f"digest mismatch: {rel}: not in {digests.DIGESTS_PATH}"
        if digests.sha256_file(path) != entry["sha256"]:
            return None, f"digest mismatch: {rel}: sha256 differs from {digests.DIGESTS_PATH}"
    on_disk = {str(p.relative_to(ds.root)): p for p in ds.data_files}
    recorded = {rel for rel in stored if rel.startswith("data/")}
    if set(on_disk) != recorded:
        extra = sorted(set(on_disk) ^ recorded)
        return None, f"digest mismatch: data files differ from {digests.DIGESTS_PATH}: {', '.join(extra[:3])}"
    for rel, path in on_disk.items():
        if path.stat().st_size != stored[rel]["size"]:
            return None, f"digest mismatch: {rel}: size differs from {digests.DIGESTS_PATH}"
    return BY_DIGESTS, ""


def pooled_scan(con: duckdb.DuckDBPyConnection, ds: DatasetSource) -> VectorScan | str:
    """What `vector_scan` finds, pooled from the episodes tables; or why their statistics cannot stand for the
    frames (a consistency check failed)."""
    labels = dimension_labels(ds)
    features = list(dict.fromkeys(key for key, *_ in labels))
    widths: dict[str, int | None] = {"length": None}
    for key in features:
        dims_of_key = sum(1 for k, *_ in labels if k == key)
        widths.update({f"stats/{key}/{s}": 1 if s == "count" else dims_of_key for s in POOLED})
    missing = [c for c in widths if c not in ds.episode_columns]
    if missing:
        return f"no per-episode stats: meta/episodes has no column {missing[0]!r}"
    reward = [f"stats/{REWARD}/{s}" for s in ("min", "max")] if REWARD in ds.data_columns else []
    reward_known = bool(reward) and all(c in ds.episode_columns for c in reward)
    if reward_known:
        widths.update(dict.fromkeys(reward, 1))
    try:
        table = pa.concat_tables(
            [read_table(f, columns=list(widths)) for f in ds.episode_files], promote_options="default"
        )
    except (DatasetError, pa.ArrowException) as exc:
        return f"episode stats unreadable: {str(exc).splitlines()[0]}"
    arrays: dict[str, npt.NDArray[np.float64]] = {}
    for column, width in widths.items():
        array = _matrix(table, column, width)
        if isinstance(array, str):
            return array
        arrays[column] = array
    lengths = arrays["length"][:, 0]
    rows = int(query(con, f"SELECT sum(num_rows) FROM parquet_file_metadata({files_sql(ds.data_files)})")[1][0][0])
    if int(lengths.sum()) != rows:
        return f"episode lengths add up to {int(lengths.sum())} frames, the data files hold {rows} rows"
    keep = lengths > 0  # an episode without frames has nothing to pool (reported by the health checks)
    dims: list[DimStats] = []
    for key in features:
        count = arrays[f"stats/{key}/count"][keep, 0]
        if not np.array_equal(count, lengths[keep]):
            return f"stats/{key}/count differs from the episode length"
        mn, mx, mean, std = (arrays[f"stats/{key}/{s}"][keep] for s in ("min", "max", "mean", "std"))
        if not all(np.isfinite(a).all() for a in (mn, mx, mean, std)):
            return f"per-episode stats of {key} hold NaN/Inf (frames with NaN/Inf: the scan skips them)"
        if (mn > mx).any() or (std < 0).any():
            return f"per-episode stats of {key} are inconsistent (min > max or std < 0)"
        total, mu, sigma = _pool(count, mean, std)
        low, high = mn.min(axis=0), mx.max(axis=0)
        for j, (i, name, expr) in enumerate((i, n, e) for k, i, n, e in labels if k == key):
            dims.append(
                DimStats(key, i, name, expr, total, float(low[j]), float(high[j]), float(mu[j]), float(sigma[j]))
            )
    finite_reward = reward_known and all(np.isfinite(arrays[c][keep]).all() for c in reward)
    # finite minima and maxima prove every reward finite; else the health checks look at the column itself
    non_finite = [ident(REWARD)] if reward and not finite_reward else []
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


def _matrix(table: pa.Table, column: str, width: int | None) -> npt.NDArray[np.float64] | str:
    """One numeric episodes-table column as an (episodes, width) array (a scalar column, width None, as
    (episodes, 1)); or what is wrong with it."""
    col = table.column(column)
    if col.null_count:
        return f"{column}: empty for some episode"
    if width is None:
        values, width = col, 1
    else:
        if not (pa.types.is_list(col.type) or pa.types.is_fixed_size_list(col.type)):
            return f"{column}: not a list column ({col.type})"
        if (pc.list_value_length(col).to_numpy(zero_copy_only=False) != width).any():
            return f"{column}: not {width} value(s) per episode"
        values = pc.list_flatten(col)
    if values.null_count or not (pa.types.is_integer(values.type) or pa.types.is_floating(values.type)):
        return f"{column}: not numbers ({values.type})"
    return np.asarray(values.to_numpy(zero_copy_only=False), dtype=np.float64).reshape(-1, width)
