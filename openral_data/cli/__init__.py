"""The `openral-data` command line: the only package that imports typer and rich. Entry point: `main`."""

import sys


def main() -> None:
    """The entry point. The command modules (typer, rich, pyarrow, ...) take most of a second to import: a Ctrl-C
    then exits 130 as one during a command does, without a traceback (so they are imported in here, not above)."""
    try:
        from openral_data.cli.app import main as run

        run()
    except KeyboardInterrupt:
        sys.exit(130)


__all__ = ["main"]
