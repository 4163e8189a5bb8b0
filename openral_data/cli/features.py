"""`openral-data features remove`: a thin typer wrapper over `edit.features`."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from openral_data import paths
from openral_data.cli.edit import report
from openral_data.formats.repo_id import resolve_dataset

features_app = typer.Typer(no_args_is_help=True, help="Remove features (cameras, columns) of a LeRobot v3 dataset.")


@features_app.command("remove")
def remove_cmd(
    dataset: Annotated[Path, typer.Argument(help="a LeRobot v3 dataset (ours or lerobot's)")],
    feature: Annotated[list[str], typer.Option(help="a feature to remove, e.g. observation.images.wrist (repeatable)")],
    out: Annotated[Path | None, typer.Option(help="new dataset folder (must not exist or be empty)")] = None,
    in_place: Annotated[bool, typer.Option(help="replace DATASET itself (swapped in once complete)")] = False,
) -> None:
    """Write DATASET without the given features (a video camera's files are not copied)."""
    from openral_data.edit.features import remove

    if out is not None:
        paths.check_creatable(out, "--out")
    report("removed", [remove(resolve_dataset(dataset), feature, out, in_place)])
