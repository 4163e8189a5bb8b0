"""`openral-data`: the Typer app, its commands (one module per command group) and the entry point."""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Annotated, Any, cast

import typer

from openral_data.cli import browse, convert, export, generate, hub, inspect, quality, record, replay, stats, upgrade
from openral_data.cli.download import dataset_commands
from openral_data.cli.edit import episodes_app
from openral_data.cli.features import features_app
from openral_data.cli.globalflags import RootGroup
from openral_data.cli.help import plain_flags
from openral_data.cli.logs import LogFormat
from openral_data.cli.logs import configure as configure_logs
from openral_data.cli.parsererrors import parser_message
from openral_data.cli.pipeline import pipeline_app
from openral_data.cli.tasks import tasks_app
from openral_data.cli.terminal import print_line
from openral_data.cli.videos import videos_app
from openral_data.errors import OpenralError, UsageError
from openral_data.manifests import ENV_DIRS, Kind
from openral_data.version import __version__

app = typer.Typer(
    cls=RootGroup,  # global flags after the command name too
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    help="Turn robot rollouts into training datasets.",
)


def _show_version(value: bool) -> None:
    if value:
        print_line(f"openral-data {__version__}")
        raise typer.Exit()


def _dir_option(kind: Kind) -> Any:
    return typer.Option(
        f"--{kind}-dir",
        help=f"also look for {kind} here, ahead of the project, user and built-in ones (sets ${ENV_DIRS[kind]})",
        metavar="DIR",
    )


@app.callback()
def _root(
    version: Annotated[
        bool,
        typer.Option("--version", help="Print the version and exit.", is_eager=True, callback=_show_version),
    ] = False,
    scenes_dir: Annotated[Path | None, _dir_option("scenes")] = None,
    rskills_dir: Annotated[Path | None, _dir_option("rskills")] = None,
    robots_dir: Annotated[Path | None, _dir_option("robots")] = None,
    verbose: Annotated[
        int,
        typer.Option(
            "--verbose", "-v", count=True, show_default=False, help="log to stderr: -v INFO (timings), -vv DEBUG"
        ),
    ] = 0,
    quiet: Annotated[
        bool, typer.Option("--quiet", "-q", help="only warnings and errors; no progress bar, no closing summary")
    ] = False,
    log_format: Annotated[
        LogFormat, typer.Option(help="text (rich on a terminal) or json (one object per line; docs/cli.md)")
    ] = LogFormat.text,
) -> None:
    """Turn robot rollouts into training datasets."""
    if verbose and quiet:
        raise UsageError("-v/--verbose and -q/--quiet: choose one")
    configure_logs(verbose, quiet, log_format)
    for kind, folder in (("scenes", scenes_dir), ("rskills", rskills_dir), ("robots", robots_dir)):
        if folder is not None:
            add_search_dir(cast(Kind, kind), folder)


def add_search_dir(kind: Kind, folder: Path) -> None:
    """Put `folder` at the top of the `kind` search path, through the environment (parallel workers inherit it)."""
    if not folder.is_dir():
        raise UsageError(f"--{kind}-dir: {folder} is not a folder")
    env = ENV_DIRS[kind]
    os.environ[env] = os.pathsep.join(p for p in (os.environ.get(env, ""), str(folder.resolve())) if p)


app.command()(record.record)
app.command()(convert.convert)
app.command()(export.export)
app.command()(upgrade.upgrade)
app.command()(inspect.info)
app.command("list")(inspect.list_cmd)
app.add_typer(stats.stats_app, name="stats")
app.command()(quality.quality)
app.command()(inspect.view)
app.command()(replay.replay)
app.command()(generate.generate)
app.command()(inspect.doctor)
app.command()(hub.push)
app.command()(browse.browse)
app.add_typer(episodes_app, name="episodes")
app.add_typer(pipeline_app, name="pipeline")
app.add_typer(videos_app, name="videos")
app.add_typer(tasks_app, name="tasks")
app.add_typer(features_app, name="features")
dataset_commands(app)  # after every command and sub-app: their @takes (--download…, v2.x) applied
plain_flags(app)  # after every command and sub-app: their --help shows no <bool> for flags


def main() -> None:
    """Entry point: a user mistake, ours or the argument parser's (an unknown option, a value not among the
    choices, a missing argument), becomes one `error:` line and exit 2."""
    try:
        code = app(standalone_mode=False)
    except OpenralError as exc:  # one line, even if a value quoted from a file held a line break
        _fail(str(exc))
    except typer.Abort:  # Ctrl-C at a prompt
        sys.exit(130)
    except typer.TyperException as exc:  # the parser's own errors (click's UsageError family)
        message = parser_message(exc)  # a typed option pydantic refused: `--codec: ...`, not pydantic's wording
        if not message.strip():  # no arguments at all: the help was printed, as for --help
            sys.exit(2)
        _fail(message)
    sys.exit(code if isinstance(code, int) else 0)


def _fail(message: str) -> None:
    print_line("error: " + " ".join(message.splitlines()), err=True)
    sys.exit(2)
