"""`stats` on real recordings: numbers against pyarrow/numpy, comparisons, formats, CLI errors, --plot."""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.compute as pc
import pyarrow.parquet as pq
import pytest
from scipy.stats import fisher_exact as scipy_fisher

from openral_data.cli.stats import stats_text
from openral_data.errors import OutputExists
from openral_data.metrics import intervals
from openral_data.metrics.command import StatsOptions, run_stats
from tests.support.cli import run_cli
from tests.support.metrics import (
    A_SUCCESS_AFTER,
    B_SUCCESS_AFTER,
    MAX_STEPS,
    copy_dataset,
    data_file,
    episodes_file,
    record_datasets,
    rewrite_parquet,
)


@pytest.fixture(scope="module")
def pair(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Path, Path]]:
    yield record_datasets(tmp_path_factory.mktemp("stats"))


def _json(paths: list[Path], **kw: Any) -> dict[str, list[dict[str, Any]]]:
    out: dict[str, list[dict[str, Any]]] = json.loads(
        run_stats(StatsOptions([str(p) for p in paths], fmt="json", **kw))
    )
    return out


def _truth(root: Path) -> dict[str, Any]:
    """The same numbers straight from pyarrow + numpy."""
    eps = pq.read_table(episodes_file(root))
    data = pq.read_table(data_file(root))
    lengths = np.asarray(eps.column("length").to_numpy())
    rows_per_ep = pc.value_counts(data.column("episode_index")).to_pylist()
    return {
        "episodes": eps.num_rows,
        "frames": data.num_rows,
        "successes": int(sum(eps.column("openral.success").to_pylist())),
        "lengths": lengths,
        "rows_per_episode": {d["values"]: d["counts"] for d in rows_per_ep},
        "data": data,
    }


def test_group_numbers_match_pyarrow(pair: tuple[Path, Path]) -> None:
    a, b = pair
    report = _json([a, b])
    groups = {g["dataset"]: g for g in report["groups"]}
    assert set(groups) == {a.name, b.name}
    for root, lengths in ((a, A_SUCCESS_AFTER), (b, B_SUCCESS_AFTER)):
        truth = _truth(root)
        g = groups[root.name]
        assert g["episodes"] == truth["episodes"] == len(lengths)
        assert g["frames"] == truth["frames"] == sum(min(x, MAX_STEPS) for x in lengths)
        assert list(truth["rows_per_episode"].values()) == list(truth["lengths"])
        assert g["successes"] == truth["successes"] == sum(x <= MAX_STEPS for x in lengths)
        assert g["success_known"] == len(lengths)
        assert g["duration_s"] == pytest.approx(truth["frames"] / 20)
        ci = intervals.wilson(g["successes"], g["episodes"])
        assert (g["ci95_low"], g["ci95_high"]) == pytest.approx((ci.low, ci.high))
        ls = truth["lengths"]
        assert g["len_min"] == ls.min() and g["len_max"] == ls.max()
        assert g["len_median"] == pytest.approx(np.median(ls))
        assert g["len_p25"] == pytest.approx(np.quantile(ls, 0.25))
        assert g["len_mean"] == pytest.approx(ls.mean())


def test_dimension_summaries_match_numpy_and_use_contract_names(pair: tuple[Path, Path]) -> None:
    a, _ = pair
    dims = [d for d in _json([a])["dimensions"] if d["dataset"] == a.name]
    info = json.loads((a / "meta/info.json").read_text())
    data = _truth(a)["data"]
    for key in ("observation.state", "action"):
        names = info["features"][key]["names"]
        rows = [d for d in dims if d["feature"] == key]
        assert [d["name"] for d in rows] == names
        values = np.asarray(data.column(key).combine_chunks().flatten()).reshape(data.num_rows, -1)
        for d in rows:
            col = values[:, d["dim"]].astype(np.float64)
            assert d["count"] == len(col)
            assert (d["min"], d["max"]) == pytest.approx((col.min(), col.max()))
            assert d["mean"] == pytest.approx(col.mean(), rel=1e-5, abs=1e-6)
            assert d["std"] == pytest.approx(col.std(), rel=1e-5, abs=1e-6)


def test_comparison_uses_newcombe_and_fisher(pair: tuple[Path, Path]) -> None:
    a, b = pair
    comp = _json([a, b])["comparison"]
    assert len(comp) == 1
    row = comp[0]
    k1, n1 = sum(x <= MAX_STEPS for x in A_SUCCESS_AFTER), len(A_SUCCESS_AFTER)
    k2, n2 = sum(x <= MAX_STEPS for x in B_SUCCESS_AFTER), len(B_SUCCESS_AFTER)
    assert (row["reference"], row["group"]) == (a.name, b.name)
    assert row["diff"] == pytest.approx(k2 / n2 - k1 / n1)
    ci = intervals.newcombe(k2, n2, k1, n1)
    assert (row["diff_low"], row["diff_high"]) == pytest.approx((ci.low, ci.high))
    assert row["diff_low"] < row["diff"] < row["diff_high"]
    assert row["p_fisher"] == pytest.approx(scipy_fisher([[k2, n2 - k2], [k1, n1 - k1]]).pvalue)


def test_group_by_rskill_and_scene(pair: tuple[Path, Path]) -> None:
    a, b = pair
    groups = _json([a, b], by="rskill,scene")["groups"]
    assert [(g["rskill"], g["scene"], g["episodes"]) for g in groups] == [
        ("random-mock", "mock_a", len(A_SUCCESS_AFTER)),
        ("zero-mock", "mock_b", len(B_SUCCESS_AFTER)),
    ]
    seeds = _json([a], by="seed")["groups"]
    assert [g["seed"] for g in seeds] == list(range(len(A_SUCCESS_AFTER)))
    assert all(g["episodes"] == 1 for g in seeds)


def test_lerobot_layout_without_our_columns(pair: tuple[Path, Path], tmp_path: Path) -> None:
    """lerobot-written datasets have no openral.* columns: success comes from next.success, else stays NULL."""
    a, _ = pair
    plain = copy_dataset(a, tmp_path / "plain")
    ep = episodes_file(plain)
    table = pq.read_table(ep)
    rewrite_parquet(ep, table.drop_columns([c for c in table.column_names if c.startswith("openral.")]))
    (plain / "meta/openral.json").unlink()
    g = _json([plain])["groups"][0]
    assert g["successes"] == sum(x <= MAX_STEPS for x in A_SUCCESS_AFTER)
    assert g["success_known"] == len(A_SUCCESS_AFTER)
    seeds = _json([plain], by="rskill,seed")["groups"]
    assert [(s["rskill"], s["seed"]) for s in seeds] == [(None, None)]

    unknown = copy_dataset(plain, tmp_path / "unknown")
    df = data_file(unknown)
    rewrite_parquet(df, pq.read_table(df).drop_columns(["next.success"]))
    g = _json([unknown])["groups"][0]
    assert g["success_known"] == 0
    assert g["successes"] is None and g["success_rate"] is None and g["ci95_low"] is None


def test_formats(pair: tuple[Path, Path]) -> None:
    a, b = pair
    paths = [str(a), str(b)]
    text = run_stats(StatsOptions(paths, fmt="csv", sql="SELECT dataset, count(*) AS n FROM episodes GROUP BY ALL"))
    rows = sorted(csv.DictReader(io.StringIO(text)), key=lambda r: r["dataset"])
    assert rows == [
        {"dataset": a.name, "n": str(len(A_SUCCESS_AFTER))},
        {"dataset": b.name, "n": str(len(B_SUCCESS_AFTER))},
    ]
    md = run_stats(StatsOptions(paths, fmt="markdown"))
    assert "### groups" in md and f"| {a.name} | {len(A_SUCCESS_AFTER)} |" in md
    table = stats_text(StatsOptions(paths, fmt="table"))
    assert "groups" in table and "health: no problems found" in table  # healthy datasets
    full_csv = run_stats(StatsOptions(paths, fmt="csv"))
    assert full_csv.startswith("# groups\n")


def test_glob_and_cli(pair: tuple[Path, Path]) -> None:
    a, _ = pair
    proc = run_cli("stats", str(a.parent / "ds_mock_*"), "--format", "json", "--by", "scene")
    assert proc.returncode == 0, proc.stderr
    assert [g["scene"] for g in json.loads(proc.stdout)["groups"]] == ["mock_a", "mock_b"]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["/nonexistent/ds"], "/nonexistent/ds: no such file or directory"),
        (["{a}", "--by", "colour"], "--by: unknown key(s) colour"),
        (["{a}", "--sql", "SELECT nope FROM frames"], "--sql: Binder Error"),
        (["{a}/meta"], "neither a LeRobot v3 dataset"),
        (["{a}", "--plot", "{tmp}/x.svg"], "--plot writes a PNG"),
        (["{a}", "--memory-limit", "lots"], "--memory-limit 'lots'"),
    ],
)
def test_cli_errors_are_one_line(pair: tuple[Path, Path], tmp_path: Path, args: list[str], message: str) -> None:
    a, _ = pair
    proc = run_cli("stats", *(x.format(a=a, tmp=tmp_path) for x in args))
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and message in lines[0], proc.stderr


def test_plot_png(pair: tuple[Path, Path], tmp_path: Path) -> None:
    a, b = pair
    png = tmp_path / "stats.png"
    run_stats(StatsOptions([str(a), str(b)], plot=png))
    data = png.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000
    with pytest.raises(OutputExists) as excinfo:
        run_stats(StatsOptions([str(a)], plot=png))
    assert excinfo.value.code == "output.exists"
    assert png.read_bytes() == data
