"""`openral-data`: the Typer app, its commands (one module per command group) and the entry point."""

from __future__ import annotations

import sys

import typer

from openral_data.cli import convert, inspect, record, replay, stats
from openral_data.cli.edit import episodes_app
from openral_data.cli.pipeline import pipeline_app
from openral_data.cli.terminal import print_line
from openral_data.errors import OpenralError

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    help="Turn robot rollouts into training datasets.",
)
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


def main() -> None:
    """Entry point: user mistakes become one `error:` line and exit 2; usage errors are click's (exit 2)."""
    try:
        app()
    except OpenralError as exc:  # one line, even if a value quoted from a file held a line break
        print_line("error: " + " ".join(str(exc).splitlines()), err=True)
        sys.exit(2)
