"""`openral-data episodes delete|filter|split|merge|trim|resample`: thin typer wrappers over `edit.ops`,
`edit.select`, `edit.trim` and `edit.resample`."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from openral_data import paths
from openral_data.cli.legacy import upgraded
from openral_data.cli.takes import takes
from openral_data.cli.terminal import print_done, progress_bar
from openral_data.errors import UsageError
from openral_data.formats.repo_id import resolve_dataset

if TYPE_CHECKING:
    from openral_data.edit.ops import EditResult

episodes_app = typer.Typer(
    no_args_is_help=True,
    help="Delete, filter, split, merge, trim and resample episodes of LeRobot v3 datasets (written to a new dataset, "
    "re-indexed).",
)


# the arguments every writing edit takes
Dataset = Annotated[Path, typer.Argument(help="a LeRobot v3 dataset (ours or lerobot's)")]
Out = Annotated[Path | None, typer.Option(help="new dataset folder (must not exist or be empty)")]
InPlace = Annotated[bool, typer.Option(help="replace DATASET itself (swapped in once complete)")]


def report(op: str, results: list[EditResult]) -> None:
    for r in results:
        print_done(f"{op}: {r.out}  episodes {r.episodes}  frames {r.frames}")


@episodes_app.command("delete")
@takes("dataset", pixels=True, v2="upgrade", writes="new or in place", episodes={"episodes": "list"})
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
@takes("dataset", pixels=True, v2="upgrade", writes="new or in place")
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
@takes("dataset", pixels=True, v2="upgrade", writes="new", episodes={"episodes": "list", "spec": "spec"})
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
    out_dir: Annotated[
        Path | None, typer.Option(help="with --fractions or --spec: parts are written to OUT_DIR/NAME")
    ] = None,
    spec: Annotated[
        str | None, typer.Option(help="instead of --episodes: named lists, e.g. train=0-39,val=40-44,test=45-49")
    ] = None,
) -> None:
    """Split DATASET: the listed episodes go to --out, the others (optionally) to --rest; with --fractions, a
    seeded random partition into OUT_DIR/NAME datasets; with --spec, named episode lists into OUT_DIR/NAME."""
    if spec is not None:
        from openral_data.edit.splits import split_spec

        if episodes is not None or out is not None or rest is not None or fractions is not None:
            raise UsageError("--spec: give --out-dir, not --episodes/--out/--rest/--fractions")
        if names is not None or seed is not None:
            raise UsageError("--spec: the names are in the spec; --names and --seed go with --fractions")
        if out_dir is None:
            raise UsageError("--out-dir: --spec needs --out-dir DIR")
        paths.check_creatable(out_dir, "--out-dir")
        report("split", split_spec(resolve_dataset(dataset), spec, out_dir))
        return
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
@takes("datasets", pixels=True, v2="upgrade", writes="new")
def merge_cmd(
    datasets: Annotated[list[Path], typer.Argument(help="datasets with the same features")],
    out: Annotated[Path, typer.Option(help="merged dataset folder (must not exist or be empty)")],
    order: Annotated[str, typer.Option(help="input (datasets in the order given) or seed")] = "input",
    rename: Annotated[
        list[str] | None,
        typer.Option(help="align a key before merging: DATASET:OLD=NEW (DATASET as given; repeatable)"),
    ] = None,
) -> None:
    """Concatenate datasets into one: keys aligned by --rename, video streams whose encoder parameters differ
    from the first dataset's re-encoded to them (the rest copied); what cannot be aligned is refused, naming both."""
    from openral_data.edit.align import merge, parse_renames

    paths.check_creatable(out, "--out")
    given = [Path(up.given) if (up := upgraded(d)) is not None else d for d in datasets]  # v2.x: not its upgrade
    renames = parse_renames(rename or [], given)
    report("merged", [merge([resolve_dataset(d) for d in datasets], out, order, renames)])


@episodes_app.command("trim")
@takes("dataset", pixels=True, v2="upgrade", writes="new or in place", episodes={"frames": "frames"})
def trim_cmd(
    dataset: Dataset,
    frames: Annotated[
        str | None, typer.Option(help="frames to drop, END included: EP:START-END or EP:FRAME, e.g. 0:0-9,3:50-59")
    ] = None,
    idle: Annotated[
        bool, typer.Option(help="drop each episode's idle head and tail (as `quality` measures them)")
    ] = False,
    min_frames: Annotated[
        int, typer.Option(help="with --idle: keep an episode whole unless this many frames remain")
    ] = 10,
    out: Out = None,
    in_place: InPlace = False,
) -> None:
    """Drop frames inside episodes (--frames, or --idle heads and tails); later frames renumbered, the episodes'
    statistics recomputed, videos cut by copying packets (only a group of pictures a cut falls inside re-encoded)."""
    from openral_data.edit.trim import trim

    if out is not None:
        paths.check_creatable(out, "--out")
    with progress_bar("trimming", "episodes") as bar:
        task = bar.add_task("", total=None)
        result, done = trim(
            resolve_dataset(dataset),
            frames,
            idle,
            min_frames,
            out,
            in_place,
            progress=lambda d, t: bar.update(task, completed=d, total=t),
        )
    report("trimmed", [result])
    print_done(f"trimmed: {done.episodes_changed} episodes, {done.frames_dropped} frames dropped")
    print_done(  # under 100 columns (docs/editing.md: what each kind of clip is)
        f"trimmed: camera clips: {done.clips_copied} cut by copying packets, {done.clips_spliced} re-encoded "
        f"at a cut only, {done.clips_encoded} re-encoded"
    )


@episodes_app.command("resample")
@takes("dataset", pixels=True, v2="upgrade", writes="new or in place")
def resample_cmd(
    dataset: Dataset,
    fps: Annotated[int, typer.Option(help="the new frame rate, below the dataset's")],
    out: Out = None,
    in_place: InPlace = False,
) -> None:
    """Lower the frame rate: output frame j is source frame floor(j * FPS_OLD / FPS) (every k-th frame for an
    integer ratio); videos re-timed (keyframes copied, other frames re-encoded), statistics recomputed."""
    from openral_data.edit.resample import resample

    if out is not None:
        paths.check_creatable(out, "--out")
    with progress_bar("resampling", "episodes") as bar:
        task = bar.add_task("", total=None)
        result, done = resample(
            resolve_dataset(dataset), fps, out, in_place, progress=lambda d, t: bar.update(task, completed=d, total=t)
        )
    report("resampled", [result])
    print_done(f"resampled: camera clips: {done.clips_copied} keyframes copied, {done.clips_encoded} re-encoded")
