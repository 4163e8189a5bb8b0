"""`openral-data generate SOURCE --scene SCENE --n N --out OUT`: many demonstrations from a few (docs/generate.md)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from openral_data import paths
from openral_data.cli.encoder_flags import VCODEC_HELP
from openral_data.cli.jsonout import JsonFlag, print_json
from openral_data.cli.takes import takes
from openral_data.cli.terminal import print_line, print_summary, progress_bar
from openral_data.formats.codec import Codec
from openral_data.runtime.parallel.choice import is_parallel

if TYPE_CHECKING:
    from openral_data.generate import GenerateOptions, GenerateSummary


@takes("source", pixels=True, v2="refused", writes="new", download=False)  # ours only
def generate(
    source: Annotated[Path, typer.Argument(help="source dataset: demonstrations in a MuJoCo tabletop scene")],
    scene: Annotated[str, typer.Option(help="scene to generate in (an id or a YAML path)")],
    n: Annotated[int, typer.Option("--n", help="episodes to keep (attempts go on until that many succeed)")],
    out: Annotated[Path, typer.Option(help="the dataset to write (must not exist or be empty)")],
    seed: Annotated[int, typer.Option(help="seed of the first attempt; attempt k uses seed+k")] = 1000,
    max_steps: Annotated[int | None, typer.Option(help="step limit per attempt (default: the scene's)")] = None,
    interpolation: Annotated[int, typer.Option(help="steps between two segments (at least)")] = 5,
    settle: Annotated[int, typer.Option(help="frames a grasp segment runs on after the gripper closes")] = 8,
    annotations: Annotated[Path | None, typer.Option(help="segments given by hand (docs/generate.md)")] = None,
    workers: Annotated[int, typer.Option(help="attempts in N processes, merged by seed")] = 1,
    executor: Annotated[str, typer.Option(help="local (processes on this machine) or ray")] = "local",
    address: Annotated[str | None, typer.Option(help="Ray cluster address (--executor ray)")] = None,
    codec: Annotated[Codec, typer.Option("--vcodec", "--codec", help=VCODEC_HELP)] = "av1",
    max_attempts: Annotated[
        int | None, typer.Option(help="the attempts' cap (default: 3 x --n); fewer kept is said, not an error")
    ] = None,
    json: JsonFlag = False,
) -> None:
    """Generate demonstrations MimicGen-style: SOURCE's successful episodes, cut into object-centric segments,
    re-targeted to new object poses in SCENE and executed until --n of them succeed (at most --max-attempts
    attempts); those are kept in OUT."""
    from openral_data.generate import GenerateOptions
    from openral_data.generate import generate as run

    paths.check_creatable(out, "--out")
    options = GenerateOptions(
        source=source,
        scene=scene,
        n=n,
        out=out,
        seed=seed,
        max_steps=max_steps,
        interpolation=interpolation,
        settle=settle,
        annotations=annotations,
        workers=workers,
        executor=executor,
        address=address,
        codec=codec,
        max_attempts=max_attempts,
    )
    summary = run(options) if is_parallel(workers, executor) else _with_progress(options)  # parallel: no ticks
    if summary.kept < summary.asked:
        print_line(
            f"warning: kept {summary.kept} of the {summary.asked} episodes asked for: the cap of "
            f"{summary.attempts} attempts was reached (--max-attempts)",
            err=True,
        )
    if json:
        print_json("generate", summary.to_json())
        return
    doc = summary.to_json()
    print_summary(f"generated: {summary.out}", [(k.replace("_", " "), str(v)) for k, v in doc.items() if k != "out"])


def _with_progress(options: GenerateOptions) -> GenerateSummary:
    """The run behind a bar: the source demonstrations are replayed and cut first (seconds), then each attempt
    runs; the bar counts the episodes kept (a failed attempt drops out of the total)."""
    from openral_data.generate import generate as run

    with progress_bar("generating", "episodes kept", "{task.fields[frames]}") as bar:
        task = bar.add_task("generate", total=options.n, frames="replaying the source demonstrations...")

        def progress(rec: object, frames: int, total: int) -> None:
            bar.update(task, total=total, advance=0 if rec is None else 1, frames=f"{frames} frames")

        return run(options, progress)
