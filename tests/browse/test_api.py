"""`browse`'s JSON API, pages and files without a browser (Starlette's TestClient): paging, sorting, the
`--where` filter through the same code as `episodes filter`, the success interval, episode facts and series,
range requests on the videos, the selection's commands, and refusals (404 for anything outside the datasets)."""

from __future__ import annotations

import json
import os
import shutil
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from starlette.testclient import TestClient

from openral_data.browse import create_app, open_catalogs
from openral_data.metrics.intervals import wilson
from openral_data.metrics.sources import open_dataset
from tests.support.inproc import run_inproc
from tests.support.lerobot_written import LENGTHS, SUCCEEDED, VIDEO_CAMERA


@pytest.fixture(scope="module")
def client(browse_dataset: Path) -> Iterator[TestClient]:
    catalogs = open_catalogs([str(browse_dataset)])
    with TestClient(create_app(catalogs), base_url="http://127.0.0.1") as c:
        yield c
    for cat in catalogs:
        cat.close()


def test_table_lists_every_episode_with_the_one_success_rule(client: TestClient) -> None:
    body = client.get("/api/d/0/episodes").json()
    assert [r["episode_index"] for r in body["rows"]] == [0, 1, 2]
    assert [r["length"] for r in body["rows"]] == LENGTHS
    assert [r["duration_s"] for r in body["rows"]] == [n / 10 for n in LENGTHS]
    assert [r["success"] for r in body["rows"]] == SUCCEEDED  # lerobot's next.success, any frame
    assert {r["task"] for r in body["rows"]} == {"push the block"}
    interval = wilson(2, 3)
    assert (body["total"], body["known"], body["successes"]) == (3, 3, 2)
    assert body["interval"] == pytest.approx([interval.low, interval.high])


def test_paging_and_sorting_happen_on_the_server(client: TestClient) -> None:
    body = client.get("/api/d/0/episodes", params={"sort": "length", "desc": "1", "limit": 2}).json()
    assert [r["episode_index"] for r in body["rows"]] == [1, 0]
    assert body["total"] == 3
    body = client.get("/api/d/0/episodes", params={"sort": "length", "desc": "1", "limit": 2, "offset": 2}).json()
    assert [r["episode_index"] for r in body["rows"]] == [2]
    bad = client.get("/api/d/0/episodes", params={"sort": "length; DROP VIEW episodes"})
    assert bad.status_code == 400 and "sort" in bad.json()["error"]


def test_where_is_the_predicate_of_episodes_filter(client: TestClient, browse_dataset: Path, tmp_path: Path) -> None:
    where = "success AND length > 4"
    body = client.get("/api/d/0/episodes", params={"where": where}).json()
    assert [r["episode_index"] for r in body["rows"]] == [0]
    assert (body["total"], body["successes"]) == (1, 1)
    out = tmp_path / "filtered"
    assert run_inproc("episodes", "filter", str(browse_dataset), "--where", where, "--out", str(out)).returncode == 0
    assert open_dataset(out).info["total_episodes"] == 1


@pytest.mark.parametrize(
    "where",
    [
        "length > (SELECT count(*) FROM read_csv('/etc/passwd'))",  # another file: external access is off
        "TRUE; COPY episodes TO '/tmp/x.csv'",  # not one predicate
        "no_such_column = 1",
    ],
)
def test_a_bad_or_escaping_where_is_one_400_line(client: TestClient, where: str) -> None:
    r = client.get("/api/d/0/episodes", params={"where": where})
    assert r.status_code == 400
    assert r.json()["error"].startswith("--where: ") and "\n" not in r.json()["error"]


def test_a_misspelt_column_is_answered_with_the_columns(client: TestClient) -> None:
    error = client.get("/api/d/0/episodes", params={"where": "sucess AND length > 4"}).json()["error"]
    assert error.startswith('--where: no column "sucess" (did you mean success?); the columns: ')
    assert {"episode_index", "length", "success", "task", "seed"} <= set(error.split("the columns: ")[1].split(", "))
    error = client.get("/api/d/0/episodes", params={"where": "quality.idel > 0"}).json()["error"]
    assert error.startswith('--where: no column "quality.idel"; the quality columns: ')
    assert "quality.idle_fraction" in error and "\n" not in error


def test_ticked_episodes_a_filter_hides_leave_the_commands(client: TestClient) -> None:
    body = client.get("/api/d/0/commands", params={"episodes": "0,1,2", "where": "length > 5"}).json()
    assert (body["picked"], body["hidden"]) == ([0, 1], [2])  # episode 2 has 4 frames: the filter hides it
    assert "--episodes 0,1 " in body["commands"]["delete"] and "--episodes 0,1 " in body["commands"]["keep"]
    body = client.get("/api/d/0/commands", params={"episodes": "2", "where": "length > 5"}).json()
    assert body["picked"] == [] and set(body["commands"]) == {"filter"}  # nothing ticked is shown: no delete


def test_previous_and_next_follow_the_filter(client: TestClient) -> None:
    assert client.get("/api/d/0/episode/1/neighbours").json() == {"previous": 0, "next": 2}
    assert client.get("/api/d/0/episode/0/neighbours").json() == {"previous": None, "next": 1}
    near = client.get("/api/d/0/episode/2/neighbours", params={"where": "length <> 9"}).json()
    assert near == {"previous": 0, "next": None}  # episode 1 (9 frames) is not among the filter's


def test_episode_facts_and_series_with_dimension_names(client: TestClient) -> None:
    ep = client.get("/api/d/0/episode/1").json()
    assert (ep["length"], ep["tasks"], ep["success"]) == (9, ["push the block"], False)
    (cam,) = ep["cameras"]
    assert cam["key"] == VIDEO_CAMERA and cam["from"] == pytest.approx(0.6) and cam["to"] == pytest.approx(1.5)
    series = client.get("/api/d/0/episode/1/series").json()
    named = {(s["feature"], s["name"]): s["values"] for s in series["series"]}
    assert list(named) == [("observation.state", n) for n in "xyz"] + [("action", "vx"), ("action", "vy")]
    assert named[("observation.state", "x")] == list(range(9))
    assert named[("observation.state", "y")] == [1.0] * 9
    assert len(series["timestamps"]) == 9
    assert client.get("/api/d/0/episode/7").status_code == 404


def test_videos_answer_range_requests(client: TestClient, browse_dataset: Path) -> None:
    (mp4,) = (browse_dataset / "videos").rglob("*.mp4")
    whole = mp4.read_bytes()
    r = client.get("/d/0/video/1/0", headers={"Range": "bytes=10-29"})
    assert r.status_code == 206
    assert r.headers["content-range"] == f"bytes 10-29/{len(whole)}"
    assert r.content == whole[10:30]
    assert client.get("/d/0/video/1/0").content == whole


def test_selection_commands_are_quoted(client: TestClient, browse_dataset: Path) -> None:
    body = client.get("/api/d/0/commands", params={"episodes": "2,0", "where": "task <> 'a b'"}).json()["commands"]
    assert (
        body["delete"] == f"openral-data episodes delete {browse_dataset} --episodes 0,2 --out {browse_dataset}-deleted"
    )
    assert body["filter"].startswith(f"openral-data episodes filter {browse_dataset} --where 'task <> '\"'\"'a b'")
    assert client.get("/api/d/0/commands", params={"episodes": "x"}).status_code == 400


@pytest.mark.parametrize(
    "url",
    [
        "/..%2f..%2fetc%2fpasswd",
        "/static/..%2f_app.py",
        "/static/%2fetc%2fpasswd",
        "//etc/passwd",
        "/d/1/",
        "/d/x/",
        "/d/0/video/1/1",
        "/d/0/video/99/0",
        "/api/d/3/episodes",
    ],
)
def test_anything_else_is_404(client: TestClient, url: str) -> None:
    assert client.get(url).status_code == 404


def test_a_video_symlinked_out_of_the_dataset_is_404(browse_dataset: Path, tmp_path: Path) -> None:
    copy = tmp_path / "ds"
    shutil.copytree(browse_dataset, copy)
    (mp4,) = (copy / "videos").rglob("*.mp4")
    outside = tmp_path / "secret.mp4"
    outside.write_bytes(b"not yours")
    mp4.unlink()
    os.symlink(outside, mp4)
    catalogs = open_catalogs([str(copy)])
    try:
        with TestClient(create_app(catalogs), base_url="http://127.0.0.1") as c:
            assert c.get("/d/0/video/0/0").status_code == 404
            assert c.get("/api/d/0/episodes").status_code == 200  # the rest still answers
    finally:
        for cat in catalogs:
            cat.close()


def test_pages_load_only_local_assets(client: TestClient) -> None:
    for page in ("/", "/d/0/", "/d/0/episode/0"):
        r = client.get(page)
        assert r.status_code == 200 and "default-src 'self'" in r.headers["content-security-policy"]
        assert "http" not in r.text  # no CDN
    assert client.get("/static/episode.js").headers["content-type"].startswith("text/javascript")


def test_cli_refuses_what_is_not_a_dataset(tmp_path: Path) -> None:
    r = run_inproc("browse", str(tmp_path))
    assert r.returncode == 2
    assert r.stderr.startswith("error: ") and r.stderr.count("\n") == 1


def test_cli_without_the_browse_extra_names_it_in_one_line(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    for name in [m for m in sys.modules if m.startswith("openral_data.browse")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "uvicorn", None)  # as if not installed
    r = run_inproc("browse", str(tmp_path))
    assert r.returncode == 2
    assert r.stderr == (
        "error: browse: needs the 'browse' extra (uvicorn missing): "
        "pip install 'openral-data[browse]' (in a checkout: uv sync --extra browse)\n"
    )


def test_episode_links_to_rerun(browse_dataset: Path) -> None:
    catalogs = open_catalogs([str(browse_dataset)])
    try:
        with TestClient(create_app(catalogs, "http://127.0.0.1:9090/?url=x"), base_url="http://127.0.0.1") as c:
            rerun = c.get("/api/d/0/episode/2").json()["rerun"]
            assert rerun == {
                "url": "http://127.0.0.1:9090/?url=x",
                "command": f"openral-data view {browse_dataset} --episode 2 --serve",
            }
    finally:
        catalogs[0].close()
    bad = run_inproc("browse", str(browse_dataset), "--rerun-url", "javascript:alert(1)")
    assert bad.returncode == 2 and bad.stderr.startswith("error: --rerun-url: ")


def test_quality_flags_are_a_column_once_computed(
    browse_dataset: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Without a cached quality table there is no such column; after `openral-data quality D` each episode's raised
    flags are shown (and sortable), as the `quality` view holds them."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))  # a lerobot-written dataset: cached outside it
    root = tmp_path / "ds"
    shutil.copytree(browse_dataset, root)
    before = open_catalogs([str(root)])
    try:
        assert "quality_flags" not in [c["key"] for c in before[0].columns]
    finally:
        before[0].close()
    assert run_inproc("quality", str(root)).returncode == 0
    sql = run_inproc("stats", str(root), "--sql", "SELECT episode_index, flags FROM quality", "--format", "json")
    want = {r["episode_index"]: ", ".join(r["flags"]) for r in json.loads(sql.stdout)["sql"]}
    catalogs = open_catalogs([str(root)])
    with TestClient(create_app(catalogs), base_url="http://127.0.0.1") as c:
        body = c.get("/api/d/0/episodes", params={"sort": "quality_flags"}).json()
    for cat in catalogs:
        cat.close()
    assert {r["episode_index"]: r["quality_flags"] for r in body["rows"]} == want
    assert any(want.values())  # lerobot_written's state holds a constant dimension: a raised flag to show
