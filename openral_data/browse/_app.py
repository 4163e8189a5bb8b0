"""The Starlette app: HTML pages and static assets (package data, served from memory by name), the JSON API and
the videos. Read-only: no route writes, runs a command or opens a path named by the URL; a video is found from
the episode's metadata (`Catalog.video`), so a URL can only reach the mp4 files of the datasets given."""

from __future__ import annotations

import os
import stat
from collections.abc import Sequence
from importlib import resources

from starlette.applications import Starlette
from starlette.exceptions import HTTPException
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, Response
from starlette.routing import Route

from openral_data.browse._catalog import Catalog, NotFoundError
from openral_data.errors import OpenralError

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


def create_app(catalogs: Sequence[Catalog]) -> Starlette:
    """The app over `catalogs` (dataset number i = `catalogs[i]`)."""
    assets = _assets()

    def asset(name: str) -> Response:
        if name not in assets:
            raise HTTPException(404)
        body, media = assets[name]
        return Response(body, media_type=media, headers={"Content-Security-Policy": _CSP})

    def catalog(request: Request) -> Catalog:
        try:
            i = int(request.path_params["ds"])
        except ValueError:
            raise HTTPException(404) from None
        if not 0 <= i < len(catalogs):
            raise HTTPException(404)
        return catalogs[i]

    def number(request: Request, name: str, default: int) -> int:
        text = request.query_params.get(name, str(default))
        try:
            return int(text)
        except ValueError:
            raise HTTPException(400, f"{name}: {text!r} is not an integer") from None

    async def index(request: Request) -> Response:
        return asset("index.html")

    async def static(request: Request) -> Response:
        return asset(request.path_params["name"])

    def table_page(request: Request) -> Response:
        catalog(request)
        return asset("table.html")

    def episode_page(request: Request) -> Response:
        catalog(request).episode(int(request.path_params["ep"]))
        return asset("episode.html")

    def datasets(request: Request) -> Response:
        return JSONResponse([c.summary() for c in catalogs])

    def episodes(request: Request) -> Response:
        q = request.query_params
        body = catalog(request).table(
            q.get("where", ""),
            q.get("sort", "episode_index"),
            q.get("desc", "0") == "1",
            number(request, "offset", 0),
            number(request, "limit", 50),
        )
        return JSONResponse(body)

    def episode(request: Request) -> Response:
        return JSONResponse(catalog(request).episode(int(request.path_params["ep"])))

    def series(request: Request) -> Response:
        return JSONResponse(catalog(request).series(int(request.path_params["ep"])))

    def commands(request: Request) -> Response:
        q = request.query_params
        try:
            picked = [int(e) for e in q.get("episodes", "").split(",") if e.strip()]
        except ValueError:
            raise HTTPException(400, "episodes: not a comma-separated list of integers") from None
        return JSONResponse(catalog(request).commands(picked, q.get("where", "")))

    def video(request: Request) -> Response:
        path = catalog(request).video(int(request.path_params["ep"]), int(request.path_params["cam"]))
        try:
            mode = os.stat(path).st_mode
        except OSError:
            raise HTTPException(404) from None
        if not stat.S_ISREG(mode):  # a FIFO or device named like an mp4 is never opened
            raise HTTPException(404)
        return FileResponse(path, media_type="video/mp4")  # answers Range requests (206) itself

    routes = [
        Route("/", index),
        Route("/static/{name}", static),
        Route("/d/{ds}/", table_page),
        Route("/d/{ds}/episode/{ep:int}", episode_page),
        Route("/d/{ds}/video/{ep:int}/{cam:int}", video),
        Route("/api/datasets", datasets),
        Route("/api/d/{ds}/episodes", episodes),
        Route("/api/d/{ds}/episode/{ep:int}", episode),
        Route("/api/d/{ds}/episode/{ep:int}/series", series),
        Route("/api/d/{ds}/commands", commands),
    ]
    return Starlette(routes=routes, exception_handlers={NotFoundError: _not_found, OpenralError: _refused})


async def _not_found(request: Request, exc: Exception) -> Response:
    return JSONResponse({"error": "not found"}, status_code=404)


async def _refused(request: Request, exc: Exception) -> Response:
    """A bad --where, sort or page: 400 with the one-line message the CLI would print."""
    return JSONResponse({"error": str(exc)}, status_code=400)
