"""The Starlette app: HTML pages and static assets (package data, served from memory by name), the JSON API and
the videos, behind `_guard.LocalOnly` (Host and Origin checked). Read-only: no route writes, runs a command or
opens a path named by the URL; a video is found from the episode's metadata (`Catalog.video`), so a URL can only
reach the mp4 files of the datasets given."""

from __future__ import annotations

import os
import stat
from collections.abc import Sequence
from importlib import resources

from starlette.applications import Starlette
from starlette.exceptions import HTTPException
from starlette.middleware import Middleware
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, Response
from starlette.routing import Route

from openral_data.browse._catalog import Catalog
from openral_data.browse._compare import compare
from openral_data.browse._guard import LocalOnly
from openral_data.errors import NotFound, OpenralError

_TYPES = {".html": "text/html; charset=utf-8", ".js": "text/javascript", ".css": "text/css"}
# pages need nothing from outside: no CDN, no inline script (the assets are ours, served from this package)
_CSP = "default-src 'self'; img-src 'self' data:; media-src 'self'; object-src 'none'; base-uri 'none'"


def _assets() -> dict[str, tuple[bytes, str]]:
    folder = resources.files("openral_data.browse") / "static"
    out = {}
    for item in folder.iterdir():
        suffix = os.path.splitext(item.name)[1]
        if suffix in _TYPES:
            out[item.name] = (item.read_bytes(), _TYPES[suffix])
    return out


def create_app(
    catalogs: Sequence[Catalog], rerun_url: str | None = None, host: str = "127.0.0.1", port: int = 0
) -> Starlette:
    """The app over `catalogs` (dataset number i = `catalogs[i]`); episode pages link to `rerun_url` (a web
    viewer `view --serve` keeps) when given. It answers only requests naming `host`:`port`, where it listens
    (port 0: any port), and its API and media only same-origin ones (`_guard.LocalOnly`)."""
    routes = [
        Route("/", _index),
        Route("/static/{name}", _static),
        Route("/favicon.ico", _no_icon),
        Route("/d/{ds}/", _table_page),
        Route("/compare", _compare_page),
        Route("/api/compare", _compare),
        Route("/d/{ds}/episode/{ep:int}", _episode_page),
        Route("/d/{ds}/video/{ep:int}/{cam:int}", _video),
        Route("/d/{ds}/depth/{ep:int}/{cam:int}/{frame:int}", _depth),
        Route("/d/{ds}/picture/{ep:int}/{feature:int}/{frame:int}", _picture),
        Route("/api/datasets", _datasets),
        Route("/api/d/{ds}/episodes", _episodes),
        Route("/api/d/{ds}/episode/{ep:int}", _episode),
        Route("/api/d/{ds}/episode/{ep:int}/series", _series),
        Route("/api/d/{ds}/episode/{ep:int}/neighbours", _neighbours),
        Route("/api/d/{ds}/episode/{ep:int}/quality", _findings),
        Route("/api/d/{ds}/commands", _commands),
    ]
    app = Starlette(
        routes=routes,
        exception_handlers={NotFound: _not_found, OpenralError: _refused},
        middleware=[Middleware(LocalOnly, host=host, port=port)],
    )
    app.state.catalogs = list(catalogs)
    app.state.assets = _assets()
    app.state.rerun_url = rerun_url
    return app


def _asset(request: Request, name: str) -> Response:
    assets: dict[str, tuple[bytes, str]] = request.app.state.assets
    if name not in assets:
        raise HTTPException(404)
    body, media = assets[name]
    return Response(body, media_type=media, headers={"Content-Security-Policy": _CSP})


def _catalog(request: Request, number: str | None = None) -> Catalog:
    """Dataset number `number` (default: the URL's `ds`); 404 for anything else."""
    catalogs: list[Catalog] = request.app.state.catalogs
    try:
        i = int(request.path_params["ds"] if number is None else number)
    except ValueError:
        raise HTTPException(404) from None
    if not 0 <= i < len(catalogs):
        raise HTTPException(404)
    return catalogs[i]


def _pair(request: Request) -> tuple[Catalog, Catalog]:
    """The datasets `?a=I&b=J` name (default 0 and 1)."""
    return _catalog(request, request.query_params.get("a", "0")), _catalog(request, request.query_params.get("b", "1"))


def _number(request: Request, name: str, default: int) -> int:
    text = request.query_params.get(name, str(default))
    try:
        return int(text)
    except ValueError:
        raise HTTPException(400, f"{name}: {text!r} is not an integer") from None


async def _index(request: Request) -> Response:
    return _asset(request, "index.html")


async def _no_icon(request: Request) -> Response:
    return Response(status_code=204)


async def _static(request: Request) -> Response:
    return _asset(request, request.path_params["name"])


def _table_page(request: Request) -> Response:
    _catalog(request)
    return _asset(request, "table.html")


def _compare_page(request: Request) -> Response:
    _pair(request)
    return _asset(request, "compare.html")


def _compare(request: Request) -> Response:
    a, b = _pair(request)
    q = request.query_params
    body = compare(a, b, q.get("where", ""), q.get("sort", "episode_index"), q.get("desc", "0") == "1", 50)
    return JSONResponse(body)


def _episode_page(request: Request) -> Response:
    _catalog(request).episode(request.path_params["ep"])  # 404 for an episode the dataset does not have
    return _asset(request, "episode.html")


def _datasets(request: Request) -> Response:
    return JSONResponse([c.summary() for c in request.app.state.catalogs])


def _episodes(request: Request) -> Response:
    q = request.query_params
    body = _catalog(request).table(
        q.get("where", ""),
        q.get("sort", "episode_index"),
        q.get("desc", "0") == "1",
        _number(request, "offset", 0),
        _number(request, "limit", 50),
    )
    return JSONResponse(body)


def _episode(request: Request) -> Response:
    catalog, index = _catalog(request), request.path_params["ep"]
    body = catalog.episode(index)
    body["rerun"] = {"url": request.app.state.rerun_url, "command": catalog.serve_command(index)}
    return JSONResponse(body)


def _series(request: Request) -> Response:
    return JSONResponse(_catalog(request).series(request.path_params["ep"]))


def _neighbours(request: Request) -> Response:
    where = request.query_params.get("where", "")
    return JSONResponse(_catalog(request).neighbours(request.path_params["ep"], where))


def _findings(request: Request) -> Response:
    return JSONResponse(_catalog(request).findings(request.path_params["ep"]))


def _commands(request: Request) -> Response:
    q = request.query_params
    try:
        picked = [int(e) for e in q.get("episodes", "").split(",") if e.strip()]
    except ValueError:
        raise HTTPException(400, "episodes: not a comma-separated list of integers") from None
    return JSONResponse(_catalog(request).commands(picked, q.get("where", "")))


def _video(request: Request) -> Response:
    path = _catalog(request).video(request.path_params["ep"], request.path_params["cam"])
    try:
        mode = os.stat(path).st_mode
    except OSError:
        raise HTTPException(404) from None
    if not stat.S_ISREG(mode):  # a FIFO or device named like an mp4 is never opened
        raise HTTPException(404)
    return FileResponse(path, media_type="video/mp4")  # answers Range requests (206) itself


def _depth(request: Request) -> Response:
    p = request.path_params
    png = _catalog(request).depth(p["ep"], p["cam"], p["frame"])
    return Response(png, media_type="image/png", headers={"Cache-Control": "max-age=3600"})


def _picture(request: Request) -> Response:
    p = request.path_params
    png = _catalog(request).picture(p["ep"], p["feature"], p["frame"])
    return Response(png, media_type="image/png", headers={"Cache-Control": "max-age=3600"})


async def _not_found(request: Request, exc: Exception) -> Response:
    return JSONResponse({"error": "not found"}, status_code=404)


async def _refused(request: Request, exc: Exception) -> Response:
    """A bad --where, sort or page: 400 with the one-line message the CLI would print."""
    return JSONResponse({"error": str(exc)}, status_code=400)
