"""`--download`, `--revision`, `--include`: every command that takes a dataset fetches a Hub repo id missing from
lerobot's cache when asked (docs/hub.md#downloading). The three options are defined here once and added, by
`dataset_commands(app)`, to each command whose `@takes` declaration (`cli/takes.py`) says it takes a dataset; a
LeRobot v2.x dataset is then read as the declaration says (in place, or through `legacy.read_as_v3`). The command
itself is unchanged: its argument, once fetched, is the cached folder its own `resolve_dataset` finds.
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from openral_data.cli import terminal
from openral_data.cli.takes import Takes, declared
from openral_data.errors import UsageError
from openral_data.formats.repo_id import looks_like_repo_id

if TYPE_CHECKING:
    from openral_data.hub import DownloadOptions

Download = Annotated[
    bool,
    typer.Option(
        "--download", help="fetch a Hub repo id missing from the local cache (lerobot's, HF_LEROBOT_HOME) first"
    ),
]
Revision = Annotated[
    str | None,
    typer.Option(
        "--revision",
        help="with --download: the branch, tag or commit (default: the codebase-version tag, v3.0)",
        metavar="REV",
    ),
]
Include = Annotated[
    list[str] | None,
    typer.Option(
        "--include",
        help="with --download: fetch meta/ and the files matching this pattern only (repeatable)",
        metavar="PATTERN",
    ),
]

_ADDED = [("download", Download, False), ("hub_revision", Revision, None), ("hub_include", Include, None)]


def dataset_commands(app: typer.Typer) -> None:
    """Apply the `@takes` declarations of every command of `app` (and its sub-apps): the three options where it
    says `download`, and its way of reading v2.x; call it once every command is registered."""
    for command in app.registered_commands:
        takes = declared(command.callback)
        if command.callback is not None and takes is not None:
            command.callback = _taking(command.callback, takes)
    for group in app.registered_groups:
        if group.typer_instance is not None:
            dataset_commands(group.typer_instance)


def _taking(command: Callable[..., Any], takes: Takes) -> Callable[..., Any]:
    """`command` reading a v2.x dataset as `takes` says, and with the three options when it `download`s: before
    it runs, each repo id its `takes.param` names that is neither a local path nor already cached with what the
    command needs is fetched (`openral_data.hub.fetch_dataset`)."""
    signature = inspect.signature(command, eval_str=True)
    assert not {name for name, *_ in _ADDED} & set(signature.parameters), command  # one meaning per option

    @functools.wraps(command)
    def run(*args: Any, **kwargs: Any) -> Any:
        if takes.download:
            _download(kwargs.pop("download"), kwargs.pop("hub_revision"), kwargs.pop("hub_include"), kwargs, takes)
        if takes.v2 != "upgrade":
            return command(*args, **kwargs)
        from openral_data.cli.legacy import read_as_v3  # (its temporary upgrade: only for these commands)

        with read_as_v3(kwargs, takes):
            return command(*args, **kwargs)

    if takes.download:
        added = [inspect.Parameter(n, inspect.Parameter.KEYWORD_ONLY, default=d, annotation=t) for n, t, d in _ADDED]
        run.__signature__ = signature.replace(parameters=[*signature.parameters.values(), *added])  # type: ignore[attr-defined]
        run.__annotations__ = {p.name: p.annotation for p in run.__signature__.parameters.values()}  # type: ignore[attr-defined]
    return run


def _download(
    download: bool, revision: str | None, include: list[str] | None, kwargs: dict[str, Any], takes: Takes
) -> None:
    if download:
        from openral_data.hub import DownloadOptions

        show = not (terminal.quiet or terminal.json_output) and terminal.err_console.is_terminal
        opts = DownloadOptions(revision, tuple(include or ()), takes.pixels, show)
        given = kwargs[takes.param]
        for arg in given if isinstance(given, list | tuple) else [given]:
            _fetch(str(arg), opts)
    elif revision is not None or include:
        raise UsageError("--revision and --include go with --download")


def _fetch(arg: str, opts: DownloadOptions) -> None:
    """Fetch `arg` when it is a repo id and not a local path (a local folder named like a repo id wins, as in
    `resolve_dataset`); a path or a glob is left to the command."""
    from openral_data.hub import fetch_dataset

    if looks_like_repo_id(arg) and not (Path(arg).exists() or Path(arg).is_symlink()):
        fetch_dataset(arg, opts)
