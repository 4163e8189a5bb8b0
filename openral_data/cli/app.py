"""`openral-data`: the Typer app, its commands (one module per command group, imported when the command is looked
up: `cli/lazy.py`) and the entry point."""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Annotated, Any, cast

import typer

from openral_data.cli.globalflags import RootGroup
from openral_data.cli.lazy import LazyCommands
from openral_data.cli.logs import LogFormat
from openral_data.cli.logs import configure as configure_logs
from openral_data.cli.parsererrors import parser_message
from openral_data.cli.terminal import print_line
from openral_data.errors import OpenralError, UsageError
from openral_data.manifests import ENV_DIRS, Kind
from openral_data.version import __version__

# every command in `--help`'s order: its name -> (module, attribute), a command function or a sub-app
COMMANDS: dict[str, tuple[str, str]] = {
    "record": ("openral_data.cli.record", "record"),
    "convert": ("openral_data.cli.convert", "convert"),
    "export": ("openral_data.cli.export", "export"),
    "upgrade": ("openral_data.cli.upgrade", "upgrade"),
    "info": ("openral_data.cli.inspect", "info"),
    "list": ("openral_data.cli.inspect", "list_cmd"),
    "quality": ("openral_data.cli.quality", "quality"),
    "view": ("openral_data.cli.inspect", "view"),
    "replay": ("openral_data.cli.replay", "replay"),
    "generate": ("openral_data.cli.generate", "generate"),
    "doctor": ("openral_data.cli.inspect", "doctor"),
    "push": ("openral_data.cli.hub", "push"),
    "browse": ("openral_data.cli.browse", "browse"),
    "stats": ("openral_data.cli.stats", "stats_app"),
    "episodes": ("openral_data.cli.edit", "episodes_app"),
    "pipeline": ("openral_data.cli.pipeline", "pipeline_app"),
    "videos": ("openral_data.cli.videos", "videos_app"),
    "tasks": ("openral_data.cli.tasks", "tasks_app"),
    "features": ("openral_data.cli.features", "features_app"),
}


class AppGroup(RootGroup):
    """The root group: its commands are `COMMANDS`, each imported when first looked up."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.commands = LazyCommands(COMMANDS)

    def list_commands(self, ctx: Any) -> list[str]:
        return list(self.commands)  # the names, in order, without importing every command


app = typer.Typer(
    cls=AppGroup,  # global flags after the command name too
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
