"""The dimension summaries pooled from verified per-episode statistics equal the full frame scan; anything that
cannot be verified (a changed episodes file, NaN frames, a foreign dataset without --trust-episode-stats) falls
back to the scan and the report says why.

Tolerances: the pooled and the scanned numbers are both sums over the same float32 values carried out in float64
(numpy's per-episode mean/std and pairwise pooling against DuckDB's aggregates), so they differ by rounding
only: min, max and count are compared exactly; means to 1e-9 of the dimension's largest magnitude (the rounding
error of a float64 sum of n terms is at worst n·2⁻⁵³ of that magnitude, 1e-10 at 10⁶ frames, far more than these
recordings have), variances to 1e-9 of its square. lerobot computes its episode stats in float32 (the std as
E[x²] − E[x]²): for its datasets the same comparison holds to 1e-6 (float32's 6e-8 epsilon, a few roundings).
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.parquet as pq
import pytest

from openral_data.formats.lerobot_v3 import digests
from openral_data.metrics.command import StatsOptions, run_stats
from tests.support.cli import run_cli
from tests.support.lerobot_written import write_lerobot_dataset
from tests.support.metrics import copy_dataset, episodes_file, record_datasets, rewrite_parquet

Report = dict[str, list[dict[str, Any]]]


@pytest.fixture(scope="module")
def pair(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Path, Path]]:
    yield record_datasets(tmp_path_factory.mktemp("episode_stats"))


def _report(paths: list[Path], **kw: Any) -> Report:
    out: Report = json.loads(run_stats(StatsOptions([str(p) for p in paths], fmt="json", **kw)))
    return out


def assert_same_dimensions(pooled: Report, scanned: Report, rel: float) -> None:
    assert len(pooled["dimensions"]) == len(scanned["dimensions"]) > 0
    for p, s in zip(pooled["dimensions"], scanned["dimensions"], strict=True):
        assert [p[k] for k in ("dataset", "feature", "dim", "name", "count", "min", "max")] == [
            s[k] for k in ("dataset", "feature", "dim", "name", "count", "min", "max")
        ]
        scale = max(abs(s["min"]), abs(s["max"]), 1e-300)
        assert math.isclose(p["mean"], s["mean"], rel_tol=0, abs_tol=rel * scale), (p, s)
        assert math.isclose(p["std"] ** 2, s["std"] ** 2, rel_tol=0, abs_tol=rel * scale**2), (p, s)


def _source(report: Report, label: str) -> dict[str, Any]:
    (row,) = [r for r in report["sources"] if r["dataset"] == label]
    return row


def test_fast_path_equals_full_scan_on_our_datasets(pair: tuple[Path, Path]) -> None:
    a, b = pair
    pooled = _report([a, b])
    scanned = _report([a, b], full_scan=True)
    for ds in (a, b):
        assert _source(pooled, ds.name)["dimensions"] == "episode_stats"
        assert _source(pooled, ds.name)["verified_by"] == "digests"
        assert _source(scanned, ds.name) == {
            "dataset": ds.name,
            "dimensions": "frame_scan",
            "verified_by": None,
            "note": "--full-scan",
        }
    assert_same_dimensions(pooled, scanned, 1e-9)
    assert pooled["groups"] == scanned["groups"]
    assert pooled["health"] == scanned["health"] == []


def _set_stat(root: Path, column: str, episode: int, value: list[float]) -> None:
    path = episodes_file(root)
    table = pq.read_table(path)
    values = table.column(column).to_pylist()
    values[episode] = value
    i = table.column_names.index(column)
    rewrite_parquet(path, table.set_column(i, column, pa.array(values, table.schema.field(column).type)))


def test_tampered_episodes_file_falls_back_to_the_scan(pair: tuple[Path, Path], tmp_path: Path) -> None:
    a, _ = pair
    before = _report([a], full_scan=True)
    tampered = copy_dataset(a, tmp_path / a.name)
    dims = len(pq.read_table(episodes_file(a)).column("stats/action/mean")[0])
    _set_stat(tampered, "stats/action/mean", 0, [99.0] * dims)
    report = _report([tampered])
    source = _source(report, a.name)
    assert source["dimensions"] == "frame_scan" and source["verified_by"] is None
    assert source["note"] == (
        f"digest mismatch: {episodes_file(a).relative_to(a)}: sha256 differs from {digests.DIGESTS_PATH}"
    )
    # the scan, not the planted mean of 99 (DuckDB's parallel sums may differ in the last bit from run to run)
    assert_same_dimensions(report, before, 1e-9)

    proc = run_cli("stats", str(tampered), "--format", "json", "--no-health")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["sources"][0]["note"].startswith("digest mismatch: meta/episodes/")


def test_a_changed_data_file_falls_back_to_the_scan(pair: tuple[Path, Path], tmp_path: Path) -> None:
    a, _ = pair
    changed = copy_dataset(a, tmp_path / a.name)
    (data,) = sorted((changed / "data").glob("*/*.parquet"))
    table = pq.read_table(data)
    rewrite_parquet(data, table.slice(1))  # one row fewer: another size
    note = _source(_report([changed], health=False), a.name)["note"]
    assert note == f"digest mismatch: {data.relative_to(changed)}: size differs from {digests.DIGESTS_PATH}"


def test_non_finite_episode_stats_fall_back_to_the_scan(pair: tuple[Path, Path], tmp_path: Path) -> None:
    """Stats a writer recorded over NaN frames are NaN: the scan summarises the finite values instead."""
    a, _ = pair
    nan = copy_dataset(a, tmp_path / a.name)
    dims = len(pq.read_table(episodes_file(a)).column("stats/action/min")[0])
    _set_stat(nan, "stats/action/min", 1, [math.nan] * dims)
    digests.refresh(nan, [episodes_file(nan)])  # as if written so: the digests vouch for the file
    note = _source(_report([nan], health=False), a.name)["note"]
    assert note == "per-episode stats of action hold NaN/Inf (frames with NaN/Inf: the scan skips them)"


def test_inconsistent_counts_fall_back_to_the_scan(pair: tuple[Path, Path], tmp_path: Path) -> None:
    a, _ = pair
    odd = copy_dataset(a, tmp_path / a.name)
    count = pq.read_table(episodes_file(a)).column("stats/observation.state/count")[2].as_py()
    _set_stat(odd, "stats/observation.state/count", 2, [count[0] + 1])
    digests.refresh(odd, [episodes_file(odd)])
    note = _source(_report([odd], health=False), a.name)["note"]
    assert note == "stats/observation.state/count differs from the episode length"


@pytest.mark.slow
def test_lerobot_written_dataset_needs_trust(tmp_path: Path) -> None:
    root = tmp_path / "lr"
    write_lerobot_dataset(root, True, environment_state=True)
    scanned = _report([root])
    assert _source(scanned, "lr") == {
        "dataset": "lr",
        "dimensions": "frame_scan",
        "verified_by": None,
        "note": f"no {digests.DIGESTS_PATH} (not written by openral-data): --trust-episode-stats uses its stats",
    }
    trusted = _report([root], trust_episode_stats=True)
    assert _source(trusted, "lr")["dimensions"] == "episode_stats"
    assert _source(trusted, "lr")["verified_by"] == "--trust-episode-stats"
    assert_same_dimensions(trusted, scanned, 1e-6)
    assert trusted["health"] == scanned["health"] == []
    for flags, source in (
        (["--trust-episode-stats"], "episode_stats"),
        (["--trust-episode-stats", "--full-scan"], "frame_scan"),
    ):
        proc = run_cli("stats", str(root), *flags, "--no-health", "--format", "json")
        assert proc.returncode == 0, proc.stderr
        assert json.loads(proc.stdout)["sources"][0]["dimensions"] == source

    # with trust, the cheap checks still hold: lengths that do not add up to the data rows are refused
    ep = episodes_file(root)
    table = pq.read_table(ep)
    i = table.column_names.index("length")
    rewrite_parquet(ep, table.set_column(i, "length", pc.add(table.column("length"), 1)))
    note = _source(_report([root], trust_episode_stats=True, health=False), "lr")["note"]
    assert note.startswith("episode lengths add up to ") and note.endswith("the data files hold 19 rows")


def test_malformed_episode_stats_fall_back_to_the_scan(pair: tuple[Path, Path], tmp_path: Path) -> None:
    """Stats columns of the wrong type or width (untrusted input) are a reason to scan, never a traceback."""
    a, _ = pair
    odd = copy_dataset(a, tmp_path / a.name)
    path = episodes_file(odd)
    table = pq.read_table(path)
    i = table.column_names.index("stats/action/std")
    rewrite_parquet(path, table.set_column(i, "stats/action/std", pa.array(["x"] * table.num_rows)))
    digests.refresh(odd, [path])
    note = _source(_report([odd], health=False), a.name)["note"]
    assert note == "stats/action/std: not a list column (string)"
    table = table.set_column(i, "stats/action/std", pa.array([[0.0]] * table.num_rows, pa.list_(pa.float64())))
    rewrite_parquet(path, table)
    digests.refresh(odd, [path])
    dims = len(pq.read_table(episodes_file(a)).column("stats/action/std")[0])
    note = _source(_report([odd], health=False), a.name)["note"]
    assert note == f"stats/action/std: not {dims} value(s) per episode"
