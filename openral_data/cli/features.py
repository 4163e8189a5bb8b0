"""`openral-data features remove|rename|add`: thin typer wrappers over `edit.features`."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from openral_data import paths
from openral_data.cli.edit import report
from openral_data.cli.takes import takes
from openral_data.formats.repo_id import resolve_dataset

features_app = typer.Typer(
    no_args_is_help=True, help="Remove, rename or add features (cameras, columns) of a LeRobot v3 dataset."
)


@features_app.command("remove")
@takes("dataset", pixels=True, v2="upgrade", writes="new or in place")
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


@features_app.command("rename")
@takes("dataset", pixels=True, v2="upgrade", writes="new or in place")
def rename_cmd(
    dataset: Annotated[Path, typer.Argument(help="a LeRobot v3 dataset (ours or lerobot's)")],
    from_: Annotated[str, typer.Option("--from", help="the feature's key, e.g. observation.images.cam")],
    to: Annotated[str, typer.Option(help="its new key, e.g. observation.images.front")],
    out: Annotated[Path | None, typer.Option(help="new dataset folder (must not exist or be empty)")] = None,
    in_place: Annotated[bool, typer.Option(help="replace DATASET itself (swapped in once complete)")] = False,
) -> None:
    """Write DATASET with a feature under a new key (a video camera's files are moved, not re-encoded)."""
    from openral_data.edit.features import rename

    if out is not None:
        paths.check_creatable(out, "--out")
    report("renamed", [rename(resolve_dataset(dataset), from_, to, out, in_place)])


@features_app.command("add")
@takes("dataset", pixels=True, v2="upgrade", writes="new or in place")
def add_cmd(
    dataset: Annotated[Path, typer.Argument(help="a LeRobot v3 dataset (ours or lerobot's)")],
    name: Annotated[str, typer.Option(help="the new feature's key, e.g. action.relative")],
    sql: Annotated[str, typer.Option(help='a DuckDB expression over the frame\'s columns, e.g. "action[7] > 0.5"')],
    dtype: Annotated[str | None, typer.Option(help="float32, int64 or bool (default: inferred)")] = None,
    shape: Annotated[int | None, typer.Option(help="values a frame (default: inferred)")] = None,
    names: Annotated[str | None, typer.Option(help="comma-separated names of the values")] = None,
    out: Annotated[Path | None, typer.Option(help="new dataset folder (must not exist or be empty)")] = None,
    in_place: Annotated[bool, typer.Option(help="replace DATASET itself (swapped in once complete)")] = False,
) -> None:
    """Write DATASET with a new per-frame feature computed by DuckDB from each frame's columns (windows over an
    episode as OVER ep; vsub/vadd/vscale for lists)."""
    from openral_data.edit.derive import add

    if out is not None:
        paths.check_creatable(out, "--out")
    given = [n.strip() for n in names.split(",")] if names else []
    report("added", [add(resolve_dataset(dataset), name, sql, out, in_place, dtype, shape, given)])
