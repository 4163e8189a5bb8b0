"""The `openral-data` command line: the only package that imports typer and rich. Entry point: `main`."""

from openral_data.cli.app import main

__all__ = ["main"]
