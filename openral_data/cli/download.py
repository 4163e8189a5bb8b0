"""`--download`, `--revision`, `--include`: every command that takes a dataset fetches a Hub repo id missing from
lerobot's cache when asked (docs/hub.md#downloading). The three options are defined here once and added, by
`dataset_download(app)`, to each command `TAKES` lists; the command itself is unchanged: its argument, once
fetched, is the cached folder its own `resolve_dataset` finds.
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

from openral_data.cli import browse, convert, edit, features, quality, replay, stats, tasks, terminal, upgrade, videos
from openral_data.cli import inspect as look
from openral_data.cli.legacy import read_as_v3
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

# the commands taking datasets: their callback -> (the parameters naming datasets, whether it reads pixels);
# `push` is not one: its --revision is the branch it pushes to
TAKES: dict[Callable[..., Any], tuple[str, bool]] = {
    look.info: ("dataset", False),
    stats.stats: ("paths", False),
    quality.quality: ("paths", True),
    tasks.list_cmd: ("dataset", False),
    look.view: ("path", True),
    browse.browse: ("paths", True),
    look.doctor: ("dataset", True),
    stats.recompute_cmd: ("dataset", True),
    replay.replay: ("dataset", True),
    convert.convert: ("src", True),
    upgrade.upgrade: ("old", True),
    edit.delete_cmd: ("dataset", True),
    edit.filter_cmd: ("dataset", True),
    edit.split_cmd: ("dataset", True),
    edit.merge_cmd: ("datasets", True),
    features.remove_cmd: ("dataset", True),
    tasks.rename_cmd: ("dataset", True),
    tasks.set_cmd: ("dataset", True),
    videos.reencode_cmd: ("dataset", True),
    videos.encode_images_cmd: ("dataset", True),
}
# the commands that read a LeRobot v2.x dataset in place (`formats.dataset`); the others read it through a
# temporary upgrade (`legacy.read_as_v3`)
READS_V2 = {look.info, stats.stats, tasks.list_cmd, look.view, look.doctor, convert.convert, upgrade.upgrade}
_ADDED = [("download", Download, False), ("hub_revision", Revision, None), ("hub_include", Include, None)]


def dataset_download(app: typer.Typer) -> None:
    """Add the three options to every command of `app` (and its sub-apps) that `TAKES` lists; call it once every
    command is registered."""
    for command in app.registered_commands:
        if command.callback in TAKES:
            param, pixels = TAKES[command.callback]
            command.callback = _with_download(command.callback, param, pixels)
    for group in app.registered_groups:
        if group.typer_instance is not None:
            dataset_download(group.typer_instance)


def _with_download(command: Callable[..., Any], param: str, pixels: bool) -> Callable[..., Any]:
    """`command` with the three options: before it runs, each repo id its `param` names that is neither a local
    path nor already cached with what the command needs is fetched (`openral_data.hub.fetch_dataset`)."""
    signature = inspect.signature(command, eval_str=True)
    assert not {name for name, *_ in _ADDED} & set(signature.parameters), command  # one meaning per option

    @functools.wraps(command)
    def run(*args: Any, download: bool, hub_revision: str | None, hub_include: list[str] | None, **kwargs: Any) -> Any:
        if download:
            from openral_data.hub import DownloadOptions

            show = not (terminal.quiet or terminal.json_output) and terminal.err_console.is_terminal
            opts = DownloadOptions(hub_revision, tuple(hub_include or ()), pixels, show)
            given = kwargs[param]
            for arg in given if isinstance(given, list | tuple) else [given]:
                _fetch(str(arg), opts)
        elif hub_revision is not None or hub_include:
            raise UsageError("--revision and --include go with --download")
        if command in READS_V2:
            return command(*args, **kwargs)
        with read_as_v3(kwargs, param):
            return command(*args, **kwargs)

    added = [inspect.Parameter(n, inspect.Parameter.KEYWORD_ONLY, default=d, annotation=t) for n, t, d in _ADDED]
    run.__signature__ = signature.replace(parameters=[*signature.parameters.values(), *added])  # type: ignore[attr-defined]
    run.__annotations__ = {p.name: p.annotation for p in run.__signature__.parameters.values()}  # type: ignore[attr-defined]
    return run


def _fetch(arg: str, opts: DownloadOptions) -> None:
    """Fetch `arg` when it is a repo id and not a local path (a local folder named like a repo id wins, as in
    `resolve_dataset`); a path or a glob is left to the command."""
    from openral_data.hub import fetch_dataset

    if looks_like_repo_id(arg) and not (Path(arg).exists() or Path(arg).is_symlink()):
        fetch_dataset(arg, opts)
