"""Episode selection by content: `filter` (a DuckDB predicate) and `split_fractions` (a seeded random partition).

Both choose episodes, then write them through `ops` (atomic, lock-aware, re-indexed, video remuxed not re-encoded).

`filter`'s predicate is evaluated over the `episodes` view `stats --sql` has (metrics/views.py: length,
duration_s, tasks, task, success, seed, scene, rskill, robot, …) plus every `openral.*` column of the dataset's
episodes metadata not already there (quote it: `"openral.success"`). Episodes for which it is false or NULL are
dropped (an unknown `success` is NULL: `success` keeps only known successes, `success IS NOT TRUE` the rest).
A predicate naming `quality` may use the episode's quality measures and flags (`quality.idle_fraction < 0.5`,
`NOT quality.flagged`; metrics/quality): the table is computed first unless it is cached and current.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from openral_data.edit.ops import EditResult, check_edit_output, write_edit, write_selection
from openral_data.edit.source import SourceDataset
from openral_data.errors import EpisodeSelectionError, UsageError
from openral_data.formats.staging import check_new_output
from openral_data.metrics.quality import mentions_quality
from openral_data.metrics.sources import open_dataset
from openral_data.metrics.where import where_connection, where_query
from openral_data.paths import safe_name

DEFAULT_NAMES = ("train", "val", "test")


def filter_episodes(dataset: Path, where: str, out: Path | None, in_place: bool = False) -> EditResult:
    """Write the episodes of `dataset` for which the SQL predicate `where` holds (in their order)."""
    src = SourceDataset(dataset)  # refuses a busy, interrupted or foreign dataset before any query
    check_edit_output(out, in_place)
    chosen = matching_episodes(dataset, where)
    keep = [(src, e) for e in chosen if e < src.total]
    if not keep:
        raise EpisodeSelectionError(
            f"--where: {where!r} matches no episode of {dataset}; nothing written", code="episodes.empty"
        )
    return write_edit(keep, dataset, out, in_place, "filter")


def matching_episodes(dataset: Path, where: str) -> list[int]:
    """The episode indices of `dataset` for which `where` is true, ascending."""
    if not where.strip():
        raise UsageError("--where: empty predicate")
    con = where_connection(open_dataset(dataset), compute_quality=mentions_quality(where))
    try:
        rows = where_query(con, "episode_index", where, "ORDER BY episode_index")
    finally:
        con.close()
    return sorted({int(r[0]) for r in rows if r[0] is not None})  # a predicate may end in a comment


# -- split by fractions --------------------------------------------------------------------------------------
def parse_fractions(text: str) -> list[float]:
    """`0.8,0.1,0.1` -> fractions, each in (0, 1], summing to 1 (within 1e-6)."""
    try:
        fractions = [float(x) for x in text.split(",")]
    except ValueError:
        raise UsageError(f"--fractions: {text!r} is not a comma-separated list of numbers") from None
    if len(fractions) < 2:
        raise UsageError(f"--fractions: {text!r}: give at least two parts, e.g. 0.8,0.2")
    if not all(math.isfinite(f) and 0 < f <= 1 for f in fractions):
        raise UsageError(f"--fractions: {text!r}: each fraction must be > 0 and <= 1")
    if abs(sum(fractions) - 1) > 1e-6:
        raise UsageError(f"--fractions: {text!r} sums to {sum(fractions):g}, not 1")
    return fractions


def part_names(names: str | None, parts: int) -> list[str]:
    """`--names` (one per fraction, distinct, each a folder name), else train,val,test cut to the part count."""
    if names is None:
        if parts > len(DEFAULT_NAMES):
            raise UsageError(f"--names: {parts} fractions need {parts} names (defaults cover 3: train,val,test)")
        return list(DEFAULT_NAMES[:parts])
    out = [safe_name(n.strip(), "--names") for n in names.split(",")]
    if len(out) != parts:
        raise UsageError(f"--names: {len(out)} names for {parts} fractions")
    if len(set(out)) != len(out):
        raise UsageError(f"--names: {names!r} repeats a name")
    return out


def part_sizes(total: int, fractions: Sequence[float]) -> list[int]:
    """Sizes summing to `total` by the largest-remainder method (ties go to the earlier part)."""
    quotas = [total * f / sum(fractions) for f in fractions]
    sizes = [math.floor(q) for q in quotas]
    by_remainder = sorted(range(len(quotas)), key=lambda i: (-(quotas[i] - sizes[i]), i))
    for i in by_remainder[: total - sum(sizes)]:
        sizes[i] += 1
    return sizes


def partition(total: int, fractions: Sequence[float], seed: int) -> list[list[int]]:
    """A seeded random partition of episodes 0..total-1 into parts of `part_sizes`, each part ascending."""
    order = [int(e) for e in np.random.default_rng(seed).permutation(total)]
    parts, start = [], 0
    for size in part_sizes(total, fractions):
        parts.append(sorted(order[start : start + size]))
        start += size
    return parts


def split_fractions(
    dataset: Path, fractions: str, out_dir: Path, names: str | None = None, seed: int = 0
) -> list[EditResult]:
    """Write a seeded random partition of `dataset`'s episodes as `out_dir/NAME` datasets, one per fraction."""
    shares = parse_fractions(fractions)
    labels = part_names(names, len(shares))
    src = SourceDataset(dataset)
    parts = partition(src.total, shares, seed)
    for label, part in zip(labels, parts, strict=True):
        if not part:
            raise EpisodeSelectionError(
                f"--fractions: {fractions} of {src.total} episodes leaves {label} empty; "
                "every part needs at least one episode",
                code="episodes.empty",
            )
    outs = [out_dir / label for label in labels]
    for out in outs:
        check_new_output(out, "--out-dir")  # every part's folder is checked before the first one is written
    return [write_selection([(src, e) for e in part], out, "split") for out, part in zip(outs, parts, strict=True)]
