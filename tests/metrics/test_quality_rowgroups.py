"""metrics/quality reads a data file a row group at a time, an episode at a time (`stream`): whatever the row
groups (an episode spanning several, several episodes in one) or the order of the rows (a shuffled foreign file
is sorted whole), the measures and per-frame rows are those of one whole-file read, and an in-order file is never
read more than one row group at once."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from openral_data.metrics.quality import DEFAULT
from openral_data.metrics.quality.compute import FrameRows, motion_pass
from openral_data.metrics.quality.episode import FINDINGS
from openral_data.metrics.sources import open_dataset
from tests.support import quality as q
from tests.support.metrics import data_file

# rows 0-10 episode 0, 11-12 episode 1, 13-15 episode 2, 16-35 episode 3, 36-41 episode 4: in row groups of 8,
# group 1 holds the tail of episode 0 and all of episodes 1 and 2, episode 3 spans groups 2 to 4
LENGTHS = [11, 2, 3, 20, 6]
GROUP = 8


@pytest.fixture(scope="module")
def dataset(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, pa.Table]:
    eps = [q.moving(n, seed) for seed, n in enumerate(LENGTHS)]
    eps[3].state[:8] = eps[3].state[7]  # an idle head, so the per-frame idle flags vary
    eps[3].action[:8] = eps[3].action[7]
    root = q.write(tmp_path_factory.mktemp("rowgroups") / "ds", eps)
    return root, pq.read_table(data_file(root))


def _measure(root: Path) -> tuple[dict[int, dict[str, Any]], pa.Table]:
    tables: list[pa.Table] = []
    rows = motion_pass(open_dataset(root), DEFAULT, tables.append)
    return rows, pa.concat_tables(tables)


def _rewrite(root: Path, table: pa.Table, group: int) -> None:
    path = data_file(root)
    pq.write_table(table, path, row_group_size=group)
    assert pq.ParquetFile(path).metadata.num_row_groups == -(-len(table) // group)


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, np.ndarray | list | tuple) and not isinstance(a, str):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return bool(a == b)


def _reads(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """The row count of every table pyarrow reads from a parquet file from now on."""
    counts: list[int] = []

    def spy(read: Callable[..., pa.Table]) -> Callable[..., pa.Table]:
        def counted(*args: Any, **kwargs: Any) -> pa.Table:
            table = read(*args, **kwargs)
            counts.append(len(table))
            return table

        return counted

    for name in ("read", "read_row_group", "read_row_groups"):
        monkeypatch.setattr(pq.ParquetFile, name, spy(getattr(pq.ParquetFile, name)))
    monkeypatch.setattr(pq, "read_table", spy(pq.read_table))
    return counts


def test_row_groups_and_shuffled_rows_give_the_whole_file_results(
    dataset: tuple[Path, pa.Table], monkeypatch: pytest.MonkeyPatch
) -> None:
    root, table = dataset
    _rewrite(root, table, len(table))  # one row group: one whole-file read
    whole_rows, whole_frames = _measure(root)
    assert sorted(whole_rows) == list(range(len(LENGTHS)))
    assert whole_frames.column("episode_index").to_pylist() == [e for e, n in enumerate(LENGTHS) for _ in range(n)]
    assert whole_frames.column("idle").to_pylist()[16:23] == [True] * 7  # episode 3's idle head
    assert whole_rows[3][FINDINGS] and whole_rows[3]["idle_head"] == 8

    _rewrite(root, table, GROUP)
    counts = _reads(monkeypatch)
    monkeypatch.setattr(FrameRows, "FLUSH", 5)  # the per-frame rows written a few episodes at a time
    rows, frames = _measure(root)
    assert counts and max(counts) <= GROUP  # never more than a row group read at once
    assert _same(rows, whole_rows) and frames.equals(whole_frames)

    shuffled = table.take(np.random.default_rng(0).permutation(len(table)))
    _rewrite(root, shuffled, GROUP)
    counts.clear()
    rows, frames = _measure(root)
    assert max(counts) == len(table)  # out of order: read whole and sorted
    assert _same(rows, whole_rows) and frames.equals(whole_frames)

    # in order but for one row of episode 0 in the last row group: the order is known before anything is written
    _rewrite(root, table.take(np.r_[0:5, 6 : len(table), 5]), GROUP)
    rows, frames = _measure(root)
    assert _same(rows, whole_rows) and frames.equals(whole_frames)
