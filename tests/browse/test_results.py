"""`browse DATASET RESULTS`: a replay or eval results folder adds its per-episode columns to the dataset's table
(sortable like the others) and its per-step errors to the episode's series; results are attached to the dataset
they name, refused alone, and read contained like a dataset."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pyarrow as pa
import pytest
from starlette.testclient import TestClient

from openral_data.browse import Browser, create_app, open_catalogs
from openral_data.errors import DatasetError, UsageError
from openral_data.formats.results import write_results
from tests.browse.pages import plots
from tests.support.home import isolated_home
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import LENGTHS
from tests.support.replay import record_mock


def _replay(dataset: Path, out: Path) -> Path:
    """Replay results of the browse dataset: episode 0 reproduced, 1 diverging at frame 3, 2 with the other
    outcome; divergence = 0.1 * frame."""
    episodes = pa.table(
        {
            "episode_index": [0, 1, 2],
            "steps": LENGTHS,
            "success_recorded": [True, False, True],
            "success_replayed": [True, False, False],
            "action_error_mean": [0.0, 0.5, 0.0],
            "action_error_max": [0.0, 1.0, 0.0],
            "divergence_mean": [0.0, 0.4, 0.0],
            "divergence_max": [0.0, 0.8, 0.0],
            "divergence_final": [0.0, 0.8, 0.0],
            "first_divergence_frame": [None, 3, None],
            "state_max_abs": [[0.0, 0.0, 0.0], [0.2, 0.9, 0.1], [0.0, 0.0, 0.0]],
        }
    )
    rows = [(e, f) for e, n in enumerate(LENGTHS) for f in range(n)]
    steps = pa.table(
        {
            "episode_index": [e for e, _ in rows],
            "frame_index": [f for _, f in rows],
            "action_error": [0.0 if e != 1 else 0.25 * f for e, f in rows],
            "divergence": [0.1 * f if e == 1 else 0.0 for e, f in rows],
        }
    )
    write_results(out, {"kind": "replay", "dataset": str(dataset), "label": "rp"}, episodes, steps)
    return out


@pytest.fixture(scope="module")
def results(browse_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _replay(browse_dataset, tmp_path_factory.mktemp("results") / "rp")


@pytest.fixture(scope="module")
def client(browse_dataset: Path, results: Path) -> Iterator[TestClient]:
    catalogs = open_catalogs([str(browse_dataset), str(results)])
    with TestClient(create_app(catalogs), base_url="http://127.0.0.1") as c:
        yield c
    for cat in catalogs:
        cat.close()


def test_results_columns_join_the_table(client: TestClient) -> None:
    body = client.get("/api/d/0/episodes").json()
    keys = [c["key"] for c in body["columns"]]
    assert keys[6:] == [
        "r0.reproduced",
        "r0.success_replayed",
        "r0.first_divergence_frame",
        "r0.state_max_abs",
        "r0.divergence_max",
        "r0.action_error_mean",
    ]
    assert "r0.action_mse" not in keys  # absent from these results: not shown
    rows = body["rows"]
    assert [r["r0.reproduced"] for r in rows] == [True, False, False]
    assert [r["r0.first_divergence_frame"] for r in rows] == [None, 3, None]
    assert [r["r0.state_max_abs"] for r in rows] == [0.0, 0.9, 0.0]
    assert body["columns"][6]["label"] == "rp: reproduced"
    assert client.get("/api/datasets").json()[0]["results"] == [{"label": "rp", "kind": "replay"}]


def test_results_columns_sort_and_keep_the_where(client: TestClient) -> None:
    body = client.get("/api/d/0/episodes", params={"sort": "r0.state_max_abs", "desc": "1"}).json()
    assert [r["episode_index"] for r in body["rows"]] == [1, 0, 2]
    body = client.get("/api/d/0/episodes", params={"where": "length > 5", "sort": "r0.reproduced"}).json()
    assert [r["episode_index"] for r in body["rows"]] == [1, 0]
    assert client.get("/api/d/0/episodes", params={"sort": "r1.reproduced"}).status_code == 400


def test_episode_shows_its_results_and_error_series(client: TestClient) -> None:
    ep = client.get("/api/d/0/episode/1").json()
    assert ep["results"]["rp: reproduced"] is False and ep["results"]["rp: first divergence frame"] == 3
    series = client.get("/api/d/0/episode/1/series").json()
    named = {(s["feature"], s["name"]): s["values"] for s in series["series"]}
    assert named[("rp (replay)", "divergence")] == pytest.approx([0.1 * f for f in range(9)])
    assert named[("rp (replay)", "action_error")] == pytest.approx([0.25 * f for f in range(9)])
    assert ("rp (replay)", "max_abs_error") not in named  # all NULL: no series
    assert len(series["timestamps"]) == 9


def test_results_alone_or_of_another_dataset_are_refused(browse_dataset: Path, results: Path, tmp_path: Path) -> None:
    with pytest.raises(UsageError, match="give the dataset too"):
        open_catalogs([str(results)])
    other = _replay(tmp_path / "elsewhere", tmp_path / "other")
    with pytest.raises(UsageError, match="not among the datasets given"):
        open_catalogs([str(browse_dataset), str(browse_dataset), str(other)])
    # with one dataset given, results naming another path are shown with it (a replay run from another folder)
    catalogs = open_catalogs([str(browse_dataset), str(other)])
    assert [r.results.label for r in catalogs[0].results] == ["rp"]
    catalogs[0].close()


def test_a_results_file_symlinked_out_is_refused(browse_dataset: Path, results: Path, tmp_path: Path) -> None:
    copy = tmp_path / "copy"
    copy.mkdir()
    for name in ("summary.json", "steps.parquet"):
        (copy / name).write_bytes((results / name).read_bytes())
    outside = tmp_path / "outside.parquet"
    outside.write_bytes((results / "episodes.parquet").read_bytes())
    os.symlink(outside, copy / "episodes.parquet")
    with pytest.raises(DatasetError, match="leads outside"):
        open_catalogs([str(browse_dataset), str(copy)])


def test_the_pages_show_the_results(browse_dataset: Path, results: Path, page: Any) -> None:
    """In Chromium: the table has the results' columns and sorts by them; the episode page plots the divergence
    with the same cursor as the other plots, lists the episode's results and links to rerun (--rerun-url)."""
    server = Browser(open_catalogs([str(browse_dataset), str(results)]), rerun_url="http://127.0.0.1:9/?url=x")
    server.start()
    try:
        page.goto(server.url + "d/0/")
        page.wait_for_function("() => document.querySelectorAll('#episodes tbody tr').length === 3")
        titles = page.eval_on_selector_all("#episodes thead th", "ths => ths.map(t => t.textContent)")
        assert "rp: reproduced" in titles and "rp: first divergence frame" in titles
        page.click("th[data-column='r0.state_max_abs']")
        page.click("th[data-column='r0.state_max_abs']")  # twice: descending
        page.wait_for_function("() => document.querySelector('#episodes tbody tr').dataset.episode === '1'")
        plotted = plots(page, server.url + "d/0/episode/1")
        assert plotted[-1] == ["rp (replay)", [["action_error", 9], ["divergence", 9]]]
        assert page.locator("svg.plot[data-feature='rp (replay)'] line.cursor").count() == 1
        assert "rp: reproduced false" in (page.text_content("#results") or "")
        assert page.get_attribute("#rerun a", "href") == "http://127.0.0.1:9/?url=x"  # browse --rerun-url
        assert page.text_content("#rerun pre") == f"openral-data view {browse_dataset} --episode 1 --serve"
    finally:
        server.close()


def test_a_real_replay_of_a_mock_recording(tmp_path: Path) -> None:
    """What `openral-data replay DATASET --out R` writes is shown: every episode reproduced, its divergence series."""
    with isolated_home(tmp_path) as home:
        dataset = record_mock(home, tmp_path / "mock").out
        assert run_inproc("replay", str(dataset), "--out", str(tmp_path / "r")).returncode == 0
    catalogs = open_catalogs([str(dataset), str(tmp_path / "r")])
    try:
        with TestClient(create_app(catalogs), base_url="http://127.0.0.1") as c:
            rows = c.get("/api/d/0/episodes").json()["rows"]
            assert [r["r0.reproduced"] for r in rows] == [True] * len(rows)
            series = c.get("/api/d/0/episode/0/series").json()
            (divergence,) = [s for s in series["series"] if s["name"] == "divergence"]
            assert divergence["feature"] == "mock actions (replay)" and len(divergence["values"]) == len(
                series["timestamps"]
            )
    finally:
        for cat in catalogs:
            cat.close()


def test_eval_results_show_the_policy_outcome_and_action_errors(browse_dataset: Path, tmp_path: Path) -> None:
    none = [None, None, None]
    episodes = pa.table(
        {
            "episode_index": [0, 1, 2],
            "steps": LENGTHS,
            "success_recorded": [True, False, True],
            "success_replayed": [False, True, None],
            **{c: none for c in ("action_error_mean", "action_error_max", "divergence_mean")},
            **{c: none for c in ("divergence_max", "divergence_final")},
            "action_mse": [[0.1, 0.3], [0.0, 0.0], [1.0, 2.0]],
        }
    ).cast(
        pa.schema(
            [
                ("episode_index", pa.int64()),
                ("steps", pa.int64()),
                ("success_recorded", pa.bool_()),
                ("success_replayed", pa.bool_()),
                *((c, pa.float64()) for c in ("action_error_mean", "action_error_max", "divergence_mean")),
                *((c, pa.float64()) for c in ("divergence_max", "divergence_final")),
                ("action_mse", pa.list_(pa.float64())),
            ]
        )
    )
    steps = pa.table({"episode_index": [0], "frame_index": [0], "action_error": [0.5], "divergence": [None]})
    write_results(tmp_path / "ev", {"kind": "eval", "dataset": str(browse_dataset), "label": "ev"}, episodes, steps)
    catalogs = open_catalogs([str(browse_dataset), str(tmp_path / "ev")])
    try:
        body = catalogs[0].table("", "episode_index", False, 0, 50)
        assert [c["label"] for c in body["columns"][6:]] == ["ev: success (policy)", "ev: action_mse (mean over dims)"]
        assert [r["r0.success_replayed"] for r in body["rows"]] == [False, True, None]
        assert [r["r0.action_mse"] for r in body["rows"]] == pytest.approx([0.2, 0.0, 1.5])
    finally:
        catalogs[0].close()
