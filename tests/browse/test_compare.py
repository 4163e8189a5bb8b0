"""`/compare?a=I&b=J`: two datasets side by side on the same columns under the same --where, with each one's
success rate and Wilson interval and the difference B - A (Newcombe interval, Fisher p) as `stats` computes them."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from starlette.testclient import TestClient

from openral_data.browse import Browser, create_app, open_catalogs
from openral_data.metrics.intervals import fisher_exact, newcombe, wilson
from tests.support.inproc import run_inproc


@pytest.fixture(scope="module")
def pair(browse_dataset: Path, tmp_path_factory: pytest.TempPathFactory) -> list[str]:
    """The browse dataset and a copy without its failed episode 1."""
    out = tmp_path_factory.mktemp("compare") / "kept"
    assert run_inproc("episodes", "delete", str(browse_dataset), "--episodes", "1", "--out", str(out)).returncode == 0
    return [str(browse_dataset), str(out)]


@pytest.fixture(scope="module")
def client(pair: list[str]) -> Iterator[TestClient]:
    catalogs = open_catalogs(pair)
    with TestClient(create_app(catalogs), base_url="http://127.0.0.1") as c:
        yield c
    for cat in catalogs:
        cat.close()


def test_both_tables_and_the_difference(client: TestClient) -> None:
    body = client.get("/api/compare", params={"a": 0, "b": 1}).json()
    assert [r["episode_index"] for r in body["a"]["rows"]] == [0, 1, 2]
    assert [r["episode_index"] for r in body["b"]["rows"]] == [0, 1]  # renumbered by the delete
    assert [c["key"] for c in body["a"]["columns"]] == [c["key"] for c in body["b"]["columns"]]
    assert (body["a"]["successes"], body["a"]["known"], body["b"]["successes"], body["b"]["known"]) == (2, 3, 2, 2)
    w = wilson(2, 2)
    assert body["b"]["interval"] == pytest.approx([w.low, w.high])
    d = newcombe(2, 2, 2, 3)
    assert body["difference"]["rate"] == pytest.approx(1 - 2 / 3)
    assert body["difference"]["interval"] == pytest.approx([d.low, d.high])
    assert body["difference"]["fisher_p"] == pytest.approx(fisher_exact(2, 3, 2, 2))


def test_the_same_where_narrows_both(client: TestClient) -> None:
    body = client.get("/api/compare", params={"a": 0, "b": 1, "where": "length > 5"}).json()
    assert [r["length"] for r in body["a"]["rows"]] == [6, 9]
    assert [r["length"] for r in body["b"]["rows"]] == [6]
    bad = client.get("/api/compare", params={"where": "nope = 1"})
    assert bad.status_code == 400 and bad.json()["error"].startswith("ds: --where: ")


@pytest.mark.parametrize("query", ["a=0&b=2", "a=x&b=1", "a=-1&b=0"])
def test_other_numbers_are_404(client: TestClient, query: str) -> None:
    assert client.get(f"/api/compare?{query}").status_code == 404
    assert client.get(f"/compare?{query}").status_code == 404


def test_the_compare_page_in_chromium(pair: list[str], page: Any) -> None:
    server = Browser(open_catalogs(pair))
    server.start()
    try:
        page.goto(server.url)
        page.click("a.compare")
        page.wait_for_selector("body[data-ready='1']")
        counts = page.eval_on_selector_all(".sides > div", "ds => ds.map(d => d.querySelectorAll('tr').length - 1)")
        assert counts == [3, 2]
        assert "B − A: 33.3 %" in (page.text_content("#difference") or "")
        page.fill("#where", "length > 5")
        page.click("#filter button")
        page.wait_for_function("() => document.querySelectorAll('#side-a tr').length === 3")
        assert page.eval_on_selector_all("#side-b tr", "trs => trs.length") == 2
    finally:
        server.close()
