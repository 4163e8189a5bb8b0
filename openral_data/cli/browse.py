"""`openral-data browse`: a local, read-only web server over datasets (openral_data.browse; docs/browse.md)."""

from __future__ import annotations

import webbrowser
from typing import TYPE_CHECKING, Annotated

import typer

from openral_data.cli.takes import takes
from openral_data.cli.terminal import print_line
from openral_data.errors import ConfigError, UsageError, install_hint
from openral_data.formats.repo_id import resolve_dataset

if TYPE_CHECKING:
    from openral_data.browse import Browser


@takes("paths", pixels=True, v2="upgrade")
def browse(
    paths: Annotated[
        list[str], typer.Argument(help="datasets (folders or cached Hub repo ids) and replay/eval results")
    ],
    host: Annotated[str, typer.Option(help="address to listen on (default: this machine only)")] = "127.0.0.1",
    port: Annotated[int, typer.Option(help="port to listen on; 0 picks a free one")] = 8765,
    open_: Annotated[bool, typer.Option("--open", help="open the page in a web browser")] = False,
    rerun_url: Annotated[
        str | None, typer.Option(help="the web viewer URL `view --serve` printed: episode pages link to it")
    ] = None,
) -> None:
    """Browse datasets in a web browser: episodes table (sortable, paged, filtered by an `episodes filter --where`
    predicate, success rate with its 95 % interval, the columns of replay/eval results given), episode pages
    (videos, state/action plots, the results' error plots), and the `episodes delete/split/filter` command for a
    selection. Read-only; serves until Ctrl-C."""
    server = start_browser([str(resolve_dataset(p)) for p in paths], host, port, rerun_url)
    print_line(f"browse: serving {len(server.catalogs)} dataset(s) at {server.url} (Ctrl-C stops)")
    if open_:
        webbrowser.open(server.url)
    server.run()


def start_browser(paths: list[str], host: str, port: int, rerun_url: str | None = None) -> Browser:
    """The server, bound; the `browse` extra (Starlette, uvicorn) is needed, refused in one line when absent."""
    if rerun_url is not None and not rerun_url.startswith(("http://", "https://")):
        raise UsageError(f"--rerun-url: {rerun_url!r}: expected the http:// URL that `view --serve` prints")
    try:
        from openral_data.browse import Browser, open_catalogs
    except ImportError as exc:
        raise ConfigError(f"browse: needs the 'browse' extra ({exc.name} missing): {install_hint('browse')}") from None
    return Browser(open_catalogs(paths), host, port, rerun_url)
