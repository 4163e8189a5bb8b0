"""Class 2 of #49, browse is a local tool: real HTTP requests to the real server (uvicorn on a socket). A Host
that is not the server's (a DNS-rebinding page's) gets 421 and no data; the API and media answer only
same-origin requests; a slow `--where` is stopped after the query limit; a `--where` that matches no episode is
an empty table (in the table and in compare), not an HTTP 500."""

from __future__ import annotations

import http.client
import json
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any
from urllib.parse import quote, urlsplit

import pytest

from openral_data.browse import Browser, open_catalogs
from tests.browse.conftest import browse_dataset  # noqa: F401  (lerobot's own three-episode dataset)

SLOW = "length > (SELECT count(*) FROM range(100000000000) a)"  # minutes of counting without a limit


@pytest.fixture(scope="module")
def server(browse_dataset: Path) -> Iterator[Browser]:  # noqa: F811
    served = Browser(open_catalogs([str(browse_dataset), str(browse_dataset)]))
    for catalog in served.catalogs:
        catalog.query_seconds = 1.0
    served.start()
    yield served
    served.close()


def _get(server: Browser, path: str, headers: dict[str, str] | None = None) -> tuple[int, bytes]:
    """GET `path` from the server's socket with exactly `headers` (Host included when given)."""
    parts = urlsplit(server.url)
    con = http.client.HTTPConnection(parts.hostname or "", parts.port, timeout=20)
    try:
        sent = dict(headers or {})
        con.putrequest("GET", path, skip_host="Host" in sent)
        for k, v in sent.items():
            con.putheader(k, v)
        con.endheaders()
        response = con.getresponse()
        return response.status, response.read()
    finally:
        con.close()


def _json(body: bytes) -> Any:
    return json.loads(body)


@pytest.mark.parametrize(
    "path", ["/api/datasets", "/api/d/0/episodes", "/api/d/0/episode/0/series", "/d/0/video/0/0", "/"]
)
def test_a_foreign_host_gets_421_and_no_data(server: Browser, path: str) -> None:
    port = int(urlsplit(server.url).port or 0)
    for host in (f"attacker.example:{port}", "attacker.example", f"127.0.0.1.nip.io:{port}", f"127.0.0.1:{port + 1}"):
        status, body = _get(server, path, {"Host": host})
        assert status == 421, (host, status, body[:200])
        assert b"push the block" not in body and b"episode_index" not in body
    for host in (f"127.0.0.1:{port}", f"localhost:{port}"):
        status, _ = _get(server, path, {"Host": host})
        assert status in (200, 206), (host, status)


def test_the_api_and_media_answer_same_origin_requests_only(server: Browser) -> None:
    own = f"http://127.0.0.1:{urlsplit(server.url).port}"
    host = {"Host": own.removeprefix("http://")}
    for path in ("/api/d/0/episodes", "/d/0/video/0/0"):
        for foreign in ({"Origin": "http://evil.example"}, {"Sec-Fetch-Site": "cross-site"}):
            status, body = _get(server, path, {**host, **foreign})
            assert status == 403 and b"episode_index" not in body, (path, foreign, status)
        status, _ = _get(server, path, {**host, "Origin": own, "Sec-Fetch-Site": "same-origin"})
        assert status in (200, 206)
    status, _ = _get(server, "/", {**host, "Sec-Fetch-Site": "cross-site"})  # a link from elsewhere opens a page
    assert status == 200


def test_a_slow_where_is_stopped_at_the_query_limit(server: Browser) -> None:
    started = time.monotonic()
    status, body = _get(server, f"/api/d/0/episodes?where={quote(SLOW)}")
    assert time.monotonic() - started < 15
    assert status == 400 and "stopped after 1 s" in _json(body)["error"], body
    status, body = _get(server, "/api/d/0/episodes")  # the connection still answers
    assert status == 200 and _json(body)["total"] == 3


def test_a_where_that_matches_nothing_is_an_empty_table(server: Browser) -> None:
    where = quote("episode_index < 0")
    status, body = _get(server, f"/api/d/0/episodes?where={where}")
    assert status == 200, body
    table = _json(body)
    assert (table["total"], table["known"], table["successes"], table["rows"]) == (0, 0, 0, [])
    assert table["rate"] is None and table["interval"] is None
    status, body = _get(server, f"/api/compare?a=0&b=1&where={where}")
    assert status == 200, body
    both = _json(body)
    assert both["a"]["rows"] == both["b"]["rows"] == [] and both["difference"] is None


@pytest.mark.parametrize(
    ("host", "served"),
    [
        ("myhost.lan:8765", True),  # the name it was told to listen on (--host myhost.lan)
        ("localhost:8765", True),
        ("attacker.example:8765", False),  # a rebinding page's name
        ("myhost.lan:9999", False),  # another port
    ],
)
def test_a_server_listening_on_a_name_answers_that_name(host: str, served: bool) -> None:
    from starlette.testclient import TestClient

    from openral_data.browse import create_app

    with TestClient(create_app([], host="myhost.lan", port=8765), base_url=f"http://{host}") as client:
        status = client.get("/").status_code
    assert (status != 421) is served, status
