"""Replay/eval results written through the results layout module, read by `stats` and validated on open."""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from openral_data.errors import OutputExists, ResultsError
from openral_data.formats import results as layout
from openral_data.metrics import intervals
from openral_data.metrics.command import StatsOptions, run_stats
from tests.support.metrics import record_datasets
from tests.support.results import make_results


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Path, Path, dict[str, np.ndarray]]]:
    base = tmp_path_factory.mktemp("results")
    a, _ = record_datasets(base)
    res, truth = make_results(a, base / "replay")
    yield a, res, truth


def test_results_summary_matches_numpy(recorded: tuple[Path, Path, dict[str, np.ndarray]]) -> None:
    a, res, truth = recorded
    report = json.loads(run_stats(StatsOptions([str(a), str(res)], fmt="json")))
    (row,) = report["results"]
    assert (row["results"], row["kind"], row["dataset"]) == ("replay-1", "replay", a.name)
    assert row["episodes"] == len(truth["recorded"])
    assert row["steps"] == len(truth["err"])
    assert row["action_error_mean"] == pytest.approx(truth["err"].mean())
    assert row["action_error_max"] == pytest.approx(truth["err"].max())
    assert row["action_error_p95"] == pytest.approx(np.quantile(truth["err"], 0.95))
    assert row["divergence_max"] == pytest.approx(truth["div"].max())
    k, n = int(truth["replayed"].sum()), len(truth["replayed"])
    assert (row["replayed_successes"], row["replayed_known"]) == (k, n)
    assert row["outcome_agree"] == int((truth["recorded"] == truth["replayed"]).sum())
    ci = intervals.wilson(k, n)
    assert (row["replayed_ci95_low"], row["replayed_ci95_high"]) == pytest.approx((ci.low, ci.high))


def test_results_views_in_sql(recorded: tuple[Path, Path, dict[str, np.ndarray]]) -> None:
    a, res, truth = recorded
    sql = (
        "SELECT e.episode_index, e.length, r.steps, s.n FROM episodes e JOIN results r USING (dataset, episode_index) "
        "JOIN (SELECT episode_index, count(*) AS n FROM result_steps GROUP BY ALL) s USING (episode_index) ORDER BY 1"
    )
    rows = json.loads(run_stats(StatsOptions([str(a), str(res)], fmt="json", sql=sql)))["sql"]
    assert len(rows) == len(truth["recorded"])
    assert all(r["length"] == r["steps"] == r["n"] for r in rows)


def test_results_only(recorded: tuple[Path, Path, dict[str, np.ndarray]]) -> None:
    _, res, _ = recorded
    report = json.loads(run_stats(StatsOptions([str(res)], fmt="json")))
    assert list(report) == ["results"]


def test_layout_is_validated(recorded: tuple[Path, Path, dict[str, np.ndarray]], tmp_path: Path) -> None:
    _, res, _ = recorded
    with pytest.raises(OutputExists) as excinfo:
        layout.write_results(res, {"kind": "replay"}, pa.table({}), pa.table({}))
    assert excinfo.value.code == "output.exists"
    # malformed results share one code; the file and field each message names are matched
    with pytest.raises(ResultsError, match=r"episodes.parquet: columns: missing") as excinfo:
        layout.write_results(tmp_path / "r", {"kind": "eval"}, pa.table({"episode_index": [0]}), pa.table({}))
    assert excinfo.value.code == "results"
    assert not (tmp_path / "r").exists()
    broken = tmp_path / "broken"
    broken.mkdir()
    for name in (layout.EPISODES, layout.STEPS):
        (broken / name).write_bytes((res / name).read_bytes())
    (broken / layout.SUMMARY).write_text(json.dumps({"format": layout.FORMAT, "kind": "dance"}))
    with pytest.raises(ResultsError, match=r"summary.json: kind: must be one of") as excinfo:
        layout.open_results(broken)
    assert excinfo.value.code == "results"
    (broken / layout.SUMMARY).write_text(json.dumps({"format": layout.FORMAT, "kind": "eval"}))
    steps = pq.read_table(res / layout.STEPS)
    pq.write_table(
        steps.set_column(2, "action_error", steps.column("action_error").cast(pa.float32())), broken / layout.STEPS
    )
    with pytest.raises(ResultsError, match=r"steps.parquet: action_error: type float") as excinfo:
        layout.open_results(broken)
    assert excinfo.value.code == "results"
