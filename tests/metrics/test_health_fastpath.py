"""The health checks' cheap per-episode pass: episodes it proves regular skip the ordered (window) check, and
broken copies that keep lerobot's elementwise rule (timestamp = frame_index / fps) are still caught."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from openral_data.metrics import health
from openral_data.metrics.command import StatsOptions, run_stats
from openral_data.metrics.sources import open_dataset
from openral_data.metrics.views import connect, query
from tests.support.metrics import copy_dataset, data_file, record_datasets, rewrite_parquet


@pytest.fixture(scope="module")
def healthy(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Path]:
    a, _ = record_datasets(tmp_path_factory.mktemp("fastpath"))
    yield a


def _checks(root: Path) -> set[tuple[int | None, str]]:
    report = json.loads(run_stats(StatsOptions([str(root)], fmt="json")))
    return {(h["episode"], h["check"]) for h in report["health"]}


def _rows(table: pa.Table, episode: int) -> np.ndarray:
    return np.flatnonzero(np.asarray(table.column("episode_index").to_numpy()) == episode)


def _regular(root: Path) -> dict[int, bool]:
    ds = open_dataset(root)
    con = connect([ds])
    try:
        rows = query(con, health.regular_sql(ds, "index", "FALSE"))[1]
    finally:
        con.close()
    return {int(ep): bool(regular) for ep, _, _, regular in rows}


def _take(table: pa.Table, episode: int, new_order: list[int], columns: list[str] | None = None) -> pa.Table:
    """`columns` (default: all) of `episode`'s rows taken in `new_order` (positions within the episode)."""
    rows = _rows(table, episode)
    take = np.arange(table.num_rows)
    take[rows] = rows[np.asarray(new_order)]
    if columns is None:
        return table.take(pa.array(take))
    for name in columns:
        i = table.schema.get_field_index(name)
        table = table.set_column(i, name, table.column(name).take(pa.array(take)))
    return table


def test_healthy_recording_is_proved_regular_without_the_ordered_check(healthy: Path) -> None:
    regular = _regular(healthy)
    assert len(regular) == 8 and all(regular.values())
    assert _checks(healthy) == set()


def test_frame_index_swapped_with_its_timestamp_is_caught(healthy: Path, tmp_path: Path) -> None:
    """Rows 2 and 3 of episode 5 swap timestamp and frame_index but keep their `index`: every row still obeys
    timestamp = frame_index / fps, only the order by `index` shows the step back (and the 2-period steps)."""
    ds = copy_dataset(healthy, tmp_path / "swapped")
    path = data_file(ds)
    rewrite_parquet(path, _take(pq.read_table(path), 5, [0, 1, 3, 2, *range(4, 10)], ["timestamp", "frame_index"]))
    regular = _regular(ds)
    assert [ep for ep, ok in regular.items() if not ok] == [5]
    assert _checks(ds) == {(5, "timestamp_non_monotonic"), (5, "timestamp_gap")}


def test_duplicated_row_is_caught(healthy: Path, tmp_path: Path) -> None:
    """Row 5 of episode 2 replaced by a copy of row 4 (all columns): row count and the elementwise rule hold,
    the duplicate `index` does not."""
    ds = copy_dataset(healthy, tmp_path / "duplicate")
    path = data_file(ds)
    table = pq.read_table(path)
    rewrite_parquet(path, _take(table, 2, [0, 1, 2, 3, 4, 4, 6, 7, 8, 9]))
    assert not _regular(ds)[2]
    assert _checks(ds) == {(2, "timestamp_non_monotonic"), (2, "timestamp_gap")}


def test_episode_split_across_files_goes_to_the_ordered_check(healthy: Path, tmp_path: Path) -> None:
    """Episode 5's last rows moved into a second data file: still healthy, but not provable in one file."""
    ds = copy_dataset(healthy, tmp_path / "split")
    path = data_file(ds)
    table = pq.read_table(path)
    rows = _rows(table, 5)
    moved = np.zeros(table.num_rows, dtype=bool)
    moved[rows[6:]] = True
    rewrite_parquet(path, table.filter(pa.array(~moved)))
    pq.write_table(table.filter(pa.array(moved)), path.with_name("file-001.parquet"))
    assert [ep for ep, ok in _regular(ds).items() if not ok] == [5]
    assert _checks(ds) == set()


@pytest.mark.parametrize("breakage", ["gap", "swap", "nan"])
def test_fast_path_finds_what_the_ordered_check_finds_on_every_episode(
    healthy: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, breakage: str
) -> None:
    ds = copy_dataset(healthy, tmp_path / breakage)
    path = data_file(ds)
    table = pq.read_table(path)
    if breakage == "gap":
        ts = np.asarray(table.column("timestamp").to_numpy(), dtype=np.float32).copy()
        ts[_rows(table, 1)[4:]] += 0.3
        table = table.set_column(table.schema.get_field_index("timestamp"), "timestamp", pa.array(ts))
    elif breakage == "swap":
        table = _take(table, 2, [0, 2, 1, *range(3, 10)], ["timestamp"])
    else:
        col = table.column("action").combine_chunks()
        values = np.asarray(col.flatten().to_numpy(), dtype=np.float32).reshape(len(col), -1).copy()
        values[_rows(table, 7)[4], 1] = np.nan
        action = pa.FixedSizeListArray.from_arrays(pa.array(values.ravel()), values.shape[1])
        table = table.set_column(table.schema.get_field_index("action"), "action", action)
    rewrite_parquet(path, table)
    fast = json.loads(run_stats(StatsOptions([str(ds)], fmt="json")))["health"]
    monkeypatch.setattr(health, "grid_tolerance", lambda fps: -1.0)  # no episode provable: all go to the window
    exact = json.loads(run_stats(StatsOptions([str(ds)], fmt="json")))["health"]
    assert fast == exact and fast
