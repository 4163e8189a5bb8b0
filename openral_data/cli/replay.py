"""`openral-data replay`: options -> `replay()`, progress bar, readable summary."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from openral_data import paths
from openral_data.cli.given import given
from openral_data.cli.jsonout import JsonFlag, print_json
from openral_data.cli.legacy import upgraded
from openral_data.cli.takes import takes
from openral_data.cli.terminal import print_line, print_summary, progress_bar
from openral_data.formats.codec import Codec
from openral_data.formats.repo_id import resolve_dataset
from openral_data.viz import DEFAULT_PORT

if TYPE_CHECKING:
    from openral_data.replay.command import ReplayOptions, ReplaySummary
    from openral_data.replay.outcome import EpisodeOutcome


Dataset = Annotated[Path, typer.Argument(help="a LeRobot v3 dataset (recorded by openral-data for sim modes)")]
Episodes = Annotated[str | None, typer.Option(help="episodes to replay, e.g. 0,3,5-7 (default: all)")]
Mode = Annotated[str, typer.Option(help="actions | policy | closed-loop")]
RSkill = Annotated[str | None, typer.Option(help="policy / closed-loop: rSkill id or path; recorded[:K]")]
Policy = Annotated[
    str | None, typer.Option(help="policy / closed-loop: a lerobot checkpoint folder or cached Hub repo id")
]
Out = Annotated[Path | None, typer.Option(help="results folder (default: a new folder under results/)")]
Tolerance = Annotated[float, typer.Option(help="max |state error| per dimension that still reproduces")]
MaxSteps = Annotated[int | None, typer.Option(help="closed-loop step limit (default: the task's)")]
Record = Annotated[Path | None, typer.Option(help="also write the replayed rollouts as a new dataset")]
Cameras = Annotated[Path | None, typer.Option(help="with --record: YAML of cameras replacing the recorded")]
RecordCodec = Annotated[Codec, typer.Option(help="video codec of --record")]
Formats = Annotated[str, typer.Option("--format", help="--record formats: lerobot, mcap or both")]
Label = Annotated[str | None, typer.Option(help="label of the results in stats")]
Instruction = Annotated[str | None, typer.Option(help="closed-loop: the policy's instruction instead of the scene's")]
Device = Annotated[
    str | None, typer.Option(help="policy / closed-loop: cpu, cuda, cuda:N, mps or auto (neural policies)")
]
SaveVideo = Annotated[bool, typer.Option("--save-video", help="closed-loop: a debug mp4 per episode in RESULTS.debug/")]
SaveVideoDir = Annotated[
    Path | None, typer.Option(help="write the --save-video mp4s to this folder instead (implies --save-video)")
]
View = Annotated[
    bool, typer.Option("--view", help="closed-loop: show the run live in rerun (a viewer, or a served stream)")
]
ViewPort = Annotated[int, typer.Option(help="--view: port of the spawned viewer or the served stream")]
ViewAddress = Annotated[
    str | None, typer.Option(help="--view: send to this running viewer instead (rerun+http://HOST:PORT/proxy)")
]


@takes("dataset", pixels=True, v2="upgrade", writes="new", episodes={"episodes": "list"})
def replay(
    ctx: typer.Context,
    dataset: Dataset,
    episodes: Episodes = None,
    mode: Mode = "actions",
    rskill: RSkill = None,
    policy: Policy = None,
    out: Out = None,
    tolerance: Tolerance = 1e-4,
    max_steps: MaxSteps = None,
    record: Record = None,
    cameras: Cameras = None,
    codec: RecordCodec = "av1",
    format: Formats = "lerobot",
    label: Label = None,
    json: JsonFlag = False,
    instruction: Instruction = None,
    device: Device = None,
    save_video: SaveVideo = False,
    save_video_dir: SaveVideoDir = None,
    view: View = False,
    view_port: ViewPort = DEFAULT_PORT,
    view_address: ViewAddress = None,
) -> None:
    """Replay recorded actions through the rebuilt scene, or evaluate a policy against recorded episodes."""
    from openral_data.replay.command import ReplayOptions
    from openral_data.runtime.sinks import parse_formats

    for option, path in (("--out", out), ("--record", record)):
        if path is not None:
            paths.check_creatable(path, option)
    source = upgraded(resolve_dataset(dataset))  # a v2.x dataset's temporary upgrade: its results name it
    opts = ReplayOptions(
        dataset=resolve_dataset(dataset),
        episodes=episodes,
        mode=mode,  # type: ignore[arg-type]  # checked by replay()
        rskill=rskill,
        policy=policy,
        out=out,
        tolerance=tolerance,
        label=label,
        max_steps=max_steps,
        record=record,
        cameras=cameras,
        codec=codec,
        formats=parse_formats(format),
        instruction=instruction,
        device=device,
        save_video=save_video,
        save_video_dir=save_video_dir,
        view=view,
        view_port=view_port,
        view_address=view_address,
        explicit=given(ctx),
        given=None if source is None else Path(source.given),
        numbers=() if source is None else source.numbers,
    )
    _report(_run(opts), opts.mode, json)


def _report(summary: ReplaySummary, mode: str, json: bool) -> None:
    if json:
        print_json("replay", summary.to_json())
        return
    print_summary("replayed" if mode == "actions" else "evaluated", summary.rows())


def _run(opts: ReplayOptions) -> ReplaySummary:
    """`replay()` under a progress bar; Ctrl-C prints what was kept and exits 130."""
    from openral_data.replay.command import replay as run

    with progress_bar(f"replay ({opts.mode})", "episodes", "{task.fields[agree]}") as bar:
        task = bar.add_task("replay", total=None, agree="")
        agree = [0, 0]

        def progress(outcome: EpisodeOutcome | None, done: int, total: int) -> None:
            if outcome is not None and outcome.success_agrees is not None:
                agree[0] += int(outcome.success_agrees)
                agree[1] += 1
            text = f"success agrees {agree[0]}/{agree[1]}" if agree[1] else ""
            bar.update(task, total=total, completed=done, agree=text)

        try:
            return run(opts, progress)
        except KeyboardInterrupt:
            bar.stop()
            kept = f"; finished episodes are kept in {opts.record}" if opts.record is not None else ""
            print_line(f"interrupted: no results written{kept}", err=True)
            raise typer.Exit(130) from None
