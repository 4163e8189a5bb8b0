"""What `convert`'s directions share on the command line: the Ctrl-C rule (`interruptible`)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING

import typer

from openral_data.cli.terminal import print_line

if TYPE_CHECKING:
    from rich.progress import Progress


@contextmanager
def interruptible(bar: Progress, dst: Path) -> Iterator[None]:
    """Ctrl-C: DST appears complete or not at all, so nothing was written to it (the staging folders, the
    workers' included, are gone); one line on stderr, exit 130."""
    try:
        yield
    except KeyboardInterrupt:
        from openral_data.runtime.parallel.channel import STOP_HELD, held

        with held(STOP_HELD):  # a second Ctrl-C does not cut the line short
            bar.stop()
            print_line(f"interrupted: nothing was written to {dst}", err=True)
        raise typer.Exit(130) from None
