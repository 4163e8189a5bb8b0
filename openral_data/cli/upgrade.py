"""`openral-data upgrade OLD NEW`: a LeRobot v2.0/v2.1 dataset written as v3.0 (docs/upgrade.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from openral_data import paths
from openral_data.cli import terminal
from openral_data.cli.takes import takes
from openral_data.cli.terminal import print_line, print_summary
from openral_data.formats.repo_id import resolve_dataset


@takes("old", pixels=True, v2="in place", writes="new")
def upgrade(
    old: Annotated[Path, typer.Argument(help="a LeRobot v2.0/v2.1 dataset folder, or a repo id in lerobot's cache")],
    new: Annotated[Path, typer.Argument(help="the v3.0 dataset to write (must not exist or be empty)")],
) -> None:
    """Write NEW, a LeRobot v3.0 dataset, from OLD (v2.0 or v2.1) with lerobot's own converter; OLD is only read."""
    from openral_data.upgrade import upgrade as run

    paths.check_creatable(new, "NEW")
    result = run(resolve_dataset(old), new, _stage)
    rows = [("from", result.version), ("episodes", str(result.episodes)), ("frames", str(result.frames))]
    if result.rewritten:
        rows.append(("rewritten", ", ".join(result.rewritten)))
    if result.computed:
        rows.append(("stats computed", ", ".join(result.computed)))
    print_summary(f"upgraded: {result.out}", rows)


def _stage(text: str) -> None:
    """Each stage on stderr as it starts (not with -q)."""
    if not terminal.quiet:
        print_line(f"upgrade: {text}", err=True)
