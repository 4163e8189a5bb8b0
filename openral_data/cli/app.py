"""`openral-data` command line."""

from __future__ import annotations

import sys
from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from openral_data import paths
from openral_data.errors import OpenralError, UsageError
from openral_data.record import registry

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    help="Turn robot rollouts into training datasets.",
)
console = Console()
err_console = Console(stderr=True)


class CodecChoice(StrEnum):
    av1 = "av1"
    h264 = "h264"


class ListWhat(StrEnum):
    scenes = "scenes"
    rskills = "rskills"
    robots = "robots"


@app.command()
def record(
    ctx: typer.Context,
    scene: Annotated[str, typer.Option(help="scene YAML path or scene id under scenes/")] = paths.DEFAULT_SCENE,
    rskill: Annotated[str, typer.Option(help="rSkill id under rskills/, or a path to rskill.yaml")] = "random-mock",
    robot: Annotated[str | None, typer.Option(help="robot id (default: the scene's robot)")] = None,
    n_episodes: Annotated[int | None, typer.Option(help="episodes to record (default: the scene's)")] = None,
    seed: Annotated[int | None, typer.Option(help="seed of the first episode; episode k uses seed+k")] = None,
    max_steps: Annotated[int | None, typer.Option(help="step limit per episode (default: the task's)")] = None,
    out: Annotated[Path | None, typer.Option(help="output folder (default: a new folder under datasets/)")] = None,
    codec: Annotated[CodecChoice, typer.Option(help="video codec")] = CodecChoice.av1,
    format: Annotated[
        str, typer.Option("--format", help="lerobot, mcap or lerobot,mcap (MCAP bags go to OUT/mcap/)")
    ] = "lerobot",
    image_format: Annotated[str, typer.Option(help="MCAP camera messages: jpeg, png or raw")] = "jpeg",
    hal: Annotated[str | None, typer.Option(help="record ROBOT_ID through its HAL at a fixed rate")] = None,
    mode: Annotated[str, typer.Option(help="--hal: sim (MuJoCo twin, or --scene) or real (hardware)")] = "sim",
    fps: Annotated[int, typer.Option(help="--hal: control and recording rate")] = 20,
    operator: Annotated[
        str, typer.Option(help="--hal: auto, keyboard, or a script like success@40,discard@10,failure")
    ] = "auto",
    safety: Annotated[str | None, typer.Option(help="--hal: clamp or refuse (default: the manifest's)")] = None,
    staleness: Annotated[float | None, typer.Option(help="--hal: camera sample age limit, s (3 periods)")] = None,
    port: Annotated[str | None, typer.Option(help="--hal --mode real: serial port (default: the manifest's)")] = None,
    resume: Annotated[
        bool, typer.Option("--resume", help="continue the recording in --out (its settings; --n-episodes = total)")
    ] = False,
    workers: Annotated[int, typer.Option(help="record in N processes, merged by seed (openral_data/parallel)")] = 1,
    executor: Annotated[str, typer.Option(help="local (processes on this machine) or ray")] = "local",
    address: Annotated[str | None, typer.Option(help="Ray cluster address (--executor ray)")] = None,
    threads_per_worker: Annotated[int | None, typer.Option(help="renderer threads per worker (LP_NUM_THREADS)")] = None,
) -> None:
    """Record episodes of SCENE driven by RSKILL into a LeRobotDataset v3 and/or ROS 2 MCAP bags."""
    if hal is not None:
        from openral_data.cli.hal import run_hal_record

        if resume or workers != 1:
            raise UsageError("--resume/--workers: not available with --hal (one robot, one new dataset)")

        run_hal_record(
            hal, mode, rskill, fps, scene if scene != paths.DEFAULT_SCENE else None, n_episodes, max_steps, seed,
            out, codec.value, format, image_format, operator, safety, staleness, port, console, err_console,
        )  # fmt: skip
        return
    hal_only = {"--mode": mode != "sim", "--fps": fps != 20, "--operator": operator != "auto", "--safety": safety,
                "--staleness": staleness, "--port": port}  # fmt: skip
    given = [name for name, value in hal_only.items() if value]
    if given:
        raise UsageError(f"{', '.join(given)}: only with --hal ROBOT_ID (a scene records at its own fps)")
    from openral_data.record.sim import RecordOptions, RecordSummary
    from openral_data.record.sim import record as run_record
    from openral_data.record.sinks import parse_formats

    opts = RecordOptions(
        scene=scene,
        rskill=rskill,
        robot=robot,
        n_episodes=n_episodes,
        seed=seed,
        max_steps=max_steps,
        out=out,
        codec=codec.value,
        formats=parse_formats(format),
        image_format=image_format,
        resume=resume,
        explicit=frozenset(
            {"format": "formats"}.get(name, name)
            for name in ctx.params
            if getattr(ctx.get_parameter_source(name), "name", "") == "COMMANDLINE"
        ),
    )
    parallel = workers != 1 or executor != "local"
    with Progress(
        TextColumn("[bold]recording"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("episodes"),
        TextColumn("{task.fields[frames]} frames"),
        TimeElapsedColumn(),
        console=err_console,
        disable=not err_console.is_terminal,
    ) as bar:
        task = bar.add_task("record", total=n_episodes, frames=0)

        def progress(rec: object, frames: int, total: int) -> None:
            bar.update(task, total=total, advance=0 if rec is None else 1, frames=frames)

        try:
            if parallel:
                from openral_data.record.parallel.run import record_parallel

                summary: RecordSummary = record_parallel(opts, workers, executor, address, threads_per_worker)
            else:
                summary = run_record(opts, progress)
        except KeyboardInterrupt:
            bar.stop()
            if parallel:  # the workers' shares are merged only at the end: nothing reaches --out
                from openral_data.record.parallel.run import find_workers_dir, kept_note, kept_worker_episodes

                target = find_workers_dir(opts.out)
                kept = kept_worker_episodes(target) if target is not None else 0
                detail = kept_note(target, kept) if target is not None and kept else "nothing was written to --out"
                err_console.print(f"interrupted: {detail}", soft_wrap=True, markup=False, highlight=False)
            else:
                err_console.print("interrupted: the episode in flight was discarded, finished episodes are kept")
            raise typer.Exit(130) from None
    _print_rows(
        "recorded",
        [
            ("output", str(summary.out)),
            *([("resumed at", f"episode {summary.resumed_at}")] if resume else []),
            *[("recovered", line) for line in summary.recovered],
            ("episodes", str(len(summary.episodes))),
            ("success rate", f"{summary.success_rate:.1%}"),
            ("frames", str(summary.frames)),
            ("frames/s", f"{summary.fps:.1f}"),
            ("formats", ",".join(summary.formats)),
            *([("mcap bags", str(summary.out / "mcap"))] if "mcap" in summary.formats else []),
            ("codec", summary.codec),
            *([("workers", f"{workers} ({executor})")] if parallel else []),
        ],
    )


@app.command()
def convert(
    src: Annotated[
        Path, typer.Argument(help="a bag (.bag, .mcap, rosbag2 folder, folder of bags) or a LeRobot v3 dataset")
    ],
    dst: Annotated[Path, typer.Argument(help="output folder (must not exist or be empty)")],
    mapping: Annotated[Path | None, typer.Option(help="mapping YAML: topics -> features (bags -> LeRobot)")] = None,
    codec: Annotated[CodecChoice, typer.Option(help="video codec (bags -> LeRobot)")] = CodecChoice.av1,
    episodes: Annotated[str | None, typer.Option(help="episodes to export, e.g. 0,3,5-7 (LeRobot -> MCAP)")] = None,
    image_format: Annotated[
        str, typer.Option(help="MCAP camera messages: jpeg, png or raw (LeRobot -> MCAP)")
    ] = "jpeg",
) -> None:
    """Convert bags/MCAP to a LeRobot v3 dataset, or a LeRobot v3 dataset to ROS 2 MCAP bags."""
    from openral_data.cli.convert import run_convert

    run_convert(src, dst, mapping, codec.value, episodes, image_format, console, err_console)


def _print_rows(title: str, rows: list[tuple[str, str]]) -> None:
    """`key: value` lines: readable in a terminal, greppable in logs, never wrapped or truncated."""
    width = max(len(k) for k, _ in rows)
    console.print(title, markup=False, highlight=False)
    for key, value in rows:
        console.print(f"  {key:<{width}}  {value}", markup=False, highlight=False, soft_wrap=True)


@app.command()
def info(dataset: Annotated[Path, typer.Argument(help="a LeRobot v3 dataset folder")]) -> None:
    """Print a dataset's summary: episodes, frames, tasks, cameras, success rate."""
    from openral_data.formats.lerobot_v3 import summarize

    s = summarize(dataset)
    rate = s.success_rate
    _print_rows(
        str(dataset),
        [
            ("episodes", str(s.episodes)),
            ("frames", str(s.frames)),
            ("fps", str(s.fps)),
            ("duration", f"{s.frames / s.fps:.1f} s"),
            ("cameras", ", ".join(s.cameras) or "-"),
            ("tasks", "; ".join(s.tasks) or "-"),
            ("robot", s.robot_type or "-"),
            ("success rate", "-" if rate is None else f"{rate:.1%} ({s.successes}/{s.episodes})"),
        ],
    )


@app.command("list")
def list_cmd(what: Annotated[ListWhat, typer.Argument(help="scenes, rskills or robots")] = ListWhat.scenes) -> None:
    """List the scenes, rSkills or robots this checkout knows."""
    from openral_data.schemas.base import load_model
    from openral_data.schemas.rskill import RSkillManifest
    from openral_data.schemas.scene import load_scene

    table = Table()
    if what is ListWhat.scenes:
        for col in ("id", "tier", "type", "robot", "path"):
            table.add_column(col)
        for sid, path in registry.scene_files().items():
            try:
                sc = load_scene(path)
                table.add_row(sid, sc.tier, sc.scene.type, sc.scene.robot or "-", str(path))
            except OpenralError as exc:
                table.add_row(sid, "[red]invalid", str(exc), "", str(path))
        table.add_row("", "", f"types: {', '.join(sorted(registry.SCENES))}", "", "")
    elif what is ListWhat.rskills:
        for col in ("id", "policy", "embodiment", "state", "action", "cameras"):
            table.add_column(col)
        for rid in registry.rskill_ids():
            try:
                rs = load_model(RSkillManifest, paths.rskills_dir() / rid / "rskill.yaml")
                table.add_row(
                    rid,
                    rs.policy,
                    ",".join(rs.embodiment_tags),
                    f"{rs.state_contract.dim} {rs.state_contract.representation}",
                    f"{rs.action_contract.dim} {rs.action_contract.representation}",
                    ",".join(rs.required_cameras) or "-",
                )
            except OpenralError as exc:
                table.add_row(rid, "[red]invalid", str(exc), "", "", "")
    else:
        for col in ("id", "embodiment", "joints", "state", "action", "cameras"):
            table.add_column(col)
        for rid in registry.robot_ids():
            try:
                rb = registry.load_robot(rid)
                table.add_row(
                    rid,
                    ",".join(rb.embodiment_tags),
                    str(len(rb.joints)),
                    str(rb.observation.state.dim),
                    str(rb.action.dim),
                    ",".join(c.name for c in rb.sensors.cameras) or "-",
                )
            except OpenralError as exc:
                table.add_row(rid, "[red]invalid", str(exc), "", "", "")
    # piped or redirected: no terminal width to fit, so never cut a cell (ids, tags and paths stay greppable)
    (console if console.is_terminal else Console(width=1000, color_system=None)).print(table)


class StatsFormat(StrEnum):
    table = "table"
    json = "json"
    csv = "csv"
    markdown = "markdown"


@app.command()
def stats(
    paths: Annotated[list[str], typer.Argument(help="datasets and/or results directories (globs allowed)")],
    by: Annotated[str | None, typer.Option(help="group by: dataset,task,rskill,scene,robot,seed")] = None,
    sql: Annotated[str | None, typer.Option(help="run this SQL on the views instead of the report")] = None,
    fmt: Annotated[StatsFormat, typer.Option("--format", help="output format")] = StatsFormat.table,
    plot: Annotated[Path | None, typer.Option(help="also write a PNG: success rates + action histograms")] = None,
    memory_limit: Annotated[str, typer.Option(help="DuckDB memory limit")] = "1GB",
    health: Annotated[bool, typer.Option(help="run the health checks")] = True,
) -> None:
    """Episodes, frames, success rates with 95 % intervals, comparisons and health, computed by DuckDB."""
    from openral_data.metrics.command import StatsOptions, run_stats

    out = run_stats(StatsOptions(paths, by, sql, fmt.value, plot, memory_limit, health))
    print(out)


@app.command()
def view(
    path: Annotated[Path, typer.Argument(help="a LeRobot v3 dataset folder or an .mcap file")],
    episode: Annotated[int, typer.Option(help="episode index")] = 0,
    save: Annotated[Path | None, typer.Option(help="write this .rrd instead of opening a viewer")] = None,
    results: Annotated[Path | None, typer.Option(help="replay/eval results directory: log divergence")] = None,
) -> None:
    """Show an episode in rerun: videos, named state/action series, task, success/done, replay divergence."""
    from openral_data.viz.rerun_view import ViewOptions, run_view

    console.print(run_view(ViewOptions(path, episode, save, results)), markup=False, highlight=False)


@app.command()
def replay(
    dataset: Annotated[Path, typer.Argument(help="a LeRobot v3 dataset (recorded by openral-data for sim modes)")],
    episodes: Annotated[str | None, typer.Option(help="episodes to replay, e.g. 0,3,5-7 (default: all)")] = None,
    mode: Annotated[str, typer.Option(help="actions | policy | closed-loop")] = "actions",
    rskill: Annotated[str | None, typer.Option(help="policy / closed-loop: rSkill id or path; recorded[:K]")] = None,
    out: Annotated[Path | None, typer.Option(help="results folder (default: a new folder under datasets/)")] = None,
    tolerance: Annotated[float, typer.Option(help="max |state error| per dimension that still reproduces")] = 1e-4,
    max_steps: Annotated[int | None, typer.Option(help="closed-loop step limit (default: the task's)")] = None,
    record: Annotated[Path | None, typer.Option(help="also write the replayed rollouts as a new dataset")] = None,
    cameras: Annotated[Path | None, typer.Option(help="with --record: YAML of cameras replacing the recorded")] = None,
    codec: Annotated[CodecChoice, typer.Option(help="video codec of --record")] = CodecChoice.av1,
    format: Annotated[str, typer.Option("--format", help="--record formats: lerobot, mcap or both")] = "lerobot",
    label: Annotated[str | None, typer.Option(help="label of the results in stats")] = None,
) -> None:
    """Replay recorded actions through the rebuilt scene, or evaluate a policy against recorded episodes."""
    from openral_data.cli.replay import run_replay
    from openral_data.record.sinks import parse_formats
    from openral_data.replay.command import ReplayOptions

    opts = ReplayOptions(
        dataset=dataset,
        episodes=episodes,
        mode=mode,  # type: ignore[arg-type]  # checked by replay()
        rskill=rskill,
        out=out,
        tolerance=tolerance,
        label=label,
        max_steps=max_steps,
        record=record,
        cameras=cameras,
        codec=codec.value,
        formats=parse_formats(format),
    )
    run_replay(opts, console, err_console)


@app.command()
def doctor(
    dataset: Annotated[Path, typer.Argument(help="a LeRobot v3 dataset folder (ours or lerobot's)")],
    repair: Annotated[bool, typer.Option("--repair", help="fix what is safely fixable (originals are kept)")] = False,
) -> None:
    """Check a dataset against lerobot 0.6.1's format rules, one line per finding; exit 1 on errors."""
    from openral_data.doctor.command import run_doctor

    text, code = run_doctor(dataset, repair)
    console.print(text, markup=False, highlight=False, soft_wrap=True)
    if code:
        raise typer.Exit(code)


def _add_subcommands() -> None:
    from openral_data.cli.edit import episodes_app
    from openral_data.cli.pipeline import pipeline_app

    app.add_typer(episodes_app, name="episodes")
    app.add_typer(pipeline_app, name="pipeline")


_add_subcommands()


def main() -> None:
    """Entry point: user mistakes become one `error:` line and exit 2; usage errors are click's (exit 2)."""
    try:
        app()
    except OpenralError as exc:
        err_console.print(f"error: {exc}", markup=False, highlight=False, soft_wrap=True)
        sys.exit(2)
