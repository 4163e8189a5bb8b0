"""`openral-data episodes delete|filter|split|merge`: thin typer wrappers over `edit.ops` and `edit.select`."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from openral_data import paths
from openral_data.cli.terminal import print_line
from openral_data.errors import UsageError
from openral_data.formats.repo_id import resolve_dataset

if TYPE_CHECKING:
    from openral_data.edit.ops import EditResult

episodes_app = typer.Typer(
    no_args_is_help=True,
    help="Delete, filter, split and merge episodes of LeRobot v3 datasets (written to a new dataset, re-indexed).",
)


def report(op: str, results: list[EditResult]) -> None:
    for r in results:
        print_line(f"{op}: {r.out}  episodes {r.episodes}  frames {r.frames}")


@episodes_app.command("delete")
def delete_cmd(
    dataset: Annotated[Path, typer.Argument(help="a LeRobot v3 dataset (ours or lerobot's)")],
    episodes: Annotated[str, typer.Option(help="episodes to delete, e.g. 0,3,5-7")],
    out: Annotated[Path | None, typer.Option(help="new dataset folder (must not exist or be empty)")] = None,
    in_place: Annotated[bool, typer.Option(help="replace DATASET itself (swapped in once complete)")] = False,
) -> None:
    """Write DATASET without the listed episodes."""
    from openral_data.edit.ops import delete

    if out is not None:
        paths.check_creatable(out, "--out")
    report("deleted", [delete(resolve_dataset(dataset), episodes, out, in_place)])


@episodes_app.command("filter")
def filter_cmd(
    dataset: Annotated[Path, typer.Argument(help="a LeRobot v3 dataset (ours or lerobot's)")],
    where: Annotated[
        str,
        typer.Option(help='DuckDB predicate over the episodes view, e.g. "success AND length > 40"'),
    ],
    out: Annotated[Path | None, typer.Option(help="new dataset folder (must not exist or be empty)")] = None,
    in_place: Annotated[bool, typer.Option(help="replace DATASET itself (swapped in once complete)")] = False,
) -> None:
    """Write DATASET with only the episodes for which --where holds (columns as in `stats --sql`'s episodes)."""
    from openral_data.edit.select import filter_episodes

    if out is not None:
        paths.check_creatable(out, "--out")
    report("filtered", [filter_episodes(resolve_dataset(dataset), where, out, in_place)])


@episodes_app.command("split")
def split_cmd(
    dataset: Annotated[Path, typer.Argument(help="a LeRobot v3 dataset (ours or lerobot's)")],
    episodes: Annotated[str | None, typer.Option(help="episodes for --out, in this order, e.g. 0-9 or 4,2")] = None,
    out: Annotated[Path | None, typer.Option(help="dataset of the listed episodes")] = None,
    rest: Annotated[Path | None, typer.Option(help="dataset of all the other episodes")] = None,
    fractions: Annotated[
        str | None, typer.Option(help="instead of --episodes: a random partition, e.g. 0.8,0.1,0.1")
    ] = None,
    names: Annotated[str | None, typer.Option(help="with --fractions: part names (default train,val,test)")] = None,
    seed: Annotated[int | None, typer.Option(help="with --fractions: the shuffle's seed (default 0)")] = None,
    out_dir: Annotated[Path | None, typer.Option(help="with --fractions: parts are written to OUT_DIR/NAME")] = None,
) -> None:
    """Split DATASET: the listed episodes go to --out, the others (optionally) to --rest; or, with --fractions,
    a seeded random partition into OUT_DIR/NAME datasets."""
    if fractions is not None:
        from openral_data.edit.select import split_fractions

        if episodes is not None or out is not None or rest is not None:
            raise UsageError("--fractions: give --out-dir, not --episodes/--out/--rest")
        if out_dir is None:
            raise UsageError("--out-dir: --fractions needs --out-dir DIR")
        paths.check_creatable(out_dir, "--out-dir")
        parts = split_fractions(resolve_dataset(dataset), fractions, out_dir, names, 0 if seed is None else seed)
        report("split", parts)
        return
    from openral_data.edit.ops import split

    if names is not None or out_dir is not None or seed is not None:
        raise UsageError("--fractions: --names, --seed and --out-dir go with --fractions")
    if episodes is None or out is None:
        raise UsageError("--episodes: give --episodes LIST --out DIR, or --fractions F,F,… --out-dir DIR")
    paths.check_creatable(out, "--out")
    if rest is not None:
        paths.check_creatable(rest, "--rest")
    report("split", split(resolve_dataset(dataset), episodes, out, rest))


@episodes_app.command("merge")
def merge_cmd(
    datasets: Annotated[list[Path], typer.Argument(help="datasets with the same features")],
    out: Annotated[Path, typer.Option(help="merged dataset folder (must not exist or be empty)")],
    order: Annotated[str, typer.Option(help="input (datasets in the order given) or seed")] = "input",
) -> None:
    """Concatenate datasets with identical features into one (mismatches are refused, naming the field)."""
    from openral_data.edit.ops import merge

    paths.check_creatable(out, "--out")
    report("merged", [merge([resolve_dataset(d) for d in datasets], out, order)])
