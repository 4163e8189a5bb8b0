"""The `openral-data` command line: the only package that imports typer and rich."""

from openral_data.cli.app import app, main

__all__ = ["app", "main"]
