"""`openral-data`: the Typer app, its commands (one module per command group) and the entry point."""

from __future__ import annotations

import sys
from typing import Annotated

import typer

from openral_data.cli import convert, inspect, record, replay, stats
from openral_data.cli.edit import episodes_app
from openral_data.cli.help import plain_flags
from openral_data.cli.pipeline import pipeline_app
from openral_data.cli.terminal import print_line
from openral_data.errors import OpenralError
from openral_data.version import __version__

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    help="Turn robot rollouts into training datasets.",
)


def _show_version(value: bool) -> None:
    if value:
        print_line(f"openral-data {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[
        bool,
        typer.Option("--version", help="Print the version and exit.", is_eager=True, callback=_show_version),
    ] = False,
) -> None:
    """Turn robot rollouts into training datasets."""


app.command()(record.record)
app.command()(convert.convert)
app.command()(inspect.info)
app.command("list")(inspect.list_cmd)
app.command()(stats.stats)
app.command()(inspect.view)
app.command()(replay.replay)
app.command()(inspect.doctor)
app.add_typer(episodes_app, name="episodes")
app.add_typer(pipeline_app, name="pipeline")
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
        message = getattr(exc, "format_message", exc.__str__)()
        if not message.strip():  # no arguments at all: the help was printed, as for --help
            sys.exit(2)
        _fail(message)
    sys.exit(code if isinstance(code, int) else 0)


def _fail(message: str) -> None:
    print_line("error: " + " ".join(message.splitlines()), err=True)
    sys.exit(2)
