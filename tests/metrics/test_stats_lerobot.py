"""`stats` and `view` on datasets written by lerobot 0.6.1 itself (no openral columns), and the benchmark's
agreement (fast path, full scan, pandas) on a generated dataset with timestamp gaps."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from rerun.chunk import RrdReader

from openral_data.metrics.command import StatsOptions, run_stats
from openral_data.viz.rerun_view import ViewOptions, run_view
from tests.support.home import REPO
from tests.support.lerobot_written import ENV_NAMES, LENGTHS, env_state, write_lerobot_dataset
from tests.support.rrd import verify


@pytest.mark.slow
def test_lerobot_written_datasets(tmp_path: Path) -> None:
    with_success, without = tmp_path / "lr_success", tmp_path / "lr_plain"
    write_lerobot_dataset(with_success, True)
    write_lerobot_dataset(without, False)
    report = json.loads(run_stats(StatsOptions([str(with_success), str(without)], fmt="json")))
    groups = {g["dataset"]: g for g in report["groups"]}
    g = groups["lr_success"]
    assert (g["episodes"], g["frames"], g["successes"], g["success_known"]) == (3, sum(LENGTHS), 2, 3)
    g = groups["lr_plain"]
    assert (g["episodes"], g["frames"], g["successes"], g["success_known"]) == (3, sum(LENGTHS), None, 0)
    assert report["comparison"] == []  # nothing to compare against an unknown success rate
    names = [d["name"] for d in report["dimensions"] if d["dataset"] == "lr_plain"]
    assert names == ["x", "y", "z", "vx", "vy"]
    assert report["health"] == []  # lerobot's mp4s hold exactly one frame per row, at the right offsets

    rrd = tmp_path / "lr.rrd"
    run_view(ViewOptions(with_success, episode=1, save=rrd))
    verify(rrd)
    rows: dict[str, int] = {}
    for chunk in RrdReader(rrd).stream():
        if not chunk.is_static:
            rows[chunk.entity_path] = rows.get(chunk.entity_path, 0) + chunk.num_rows
    assert rows["/cameras/cam"] == rows["/state/x"] == rows["/action/vy"] == LENGTHS[1]


@pytest.mark.slow
def test_environment_state_dimensions(tmp_path: Path) -> None:
    """lerobot's `observation.environment_state` gets a row per dimension, by name, after state and action."""
    root = tmp_path / "lr_env"
    write_lerobot_dataset(root, False, environment_state=True)
    report = json.loads(run_stats(StatsOptions([str(root)], fmt="json")))
    env = [d for d in report["dimensions"] if d["feature"] == "observation.environment_state"]
    assert [d["name"] for d in report["dimensions"]] == ["x", "y", "z", "vx", "vy", *ENV_NAMES]
    values = [env_state(e, t).astype(float) for e, n in enumerate(LENGTHS) for t in range(n)]
    for i, d in enumerate(env):
        column = [v[i] for v in values]
        assert (d["dim"], d["count"], d["min"], d["max"]) == (i, sum(LENGTHS), min(column), max(column))
        assert d["mean"] == pytest.approx(sum(column) / len(column))
    assert report["health"] == []


@pytest.mark.slow
def test_benchmark_contestants_agree(tmp_path: Path) -> None:
    """bench_stats.py exits 1 when the fast path, the full scan and pandas disagree on any number (or the fast
    path is not taken); speed is not asserted here."""
    results = tmp_path / "results.json"
    cmd = [sys.executable, str(REPO / "benchmarks/bench_stats.py"), "--sizes", "30000", "--repeats", "1"]
    cmd += [
        "--health",
        "--rows-per-file",
        "12000",
        "--row-group",
        "5000",
        "--tmp",
        str(tmp_path),
        "--results",
        str(results),
    ]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    (run,) = json.loads(results.read_text())["sizes"].values()
    assert run["same_numbers"] and run["dataset"]["frames"] >= 30000 and run["dataset"]["data_files"] >= 3
    assert set(run["median_seconds"]) == {"fast", "scan", "pandas"}
    assert run["health_issues_found"] > 0  # the generated timestamp gaps, found alike by all three
    assert [p.name for p in tmp_path.iterdir()] == ["results.json"]  # the generated dataset is removed
