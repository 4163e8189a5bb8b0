"""`openral-data` command line."""

from __future__ import annotations

import sys
from enum import Enum
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from openral_data import paths, registry
from openral_data.errors import OpenralError

app = typer.Typer(add_completion=False, no_args_is_help=True, help="Turn robot rollouts into training datasets.")
console = Console()
err_console = Console(stderr=True)


class CodecChoice(str, Enum):
    av1 = "av1"
    h264 = "h264"


class ListWhat(str, Enum):
    scenes = "scenes"
    rskills = "rskills"
    robots = "robots"


@app.command()
def record(
    scene: Annotated[str, typer.Option(help="scene YAML path or scene id under scenes/")] = paths.DEFAULT_SCENE,
    rskill: Annotated[str, typer.Option(help="rSkill id under rskills/, or a path to rskill.yaml")] = "random-mock",
    robot: Annotated[str | None, typer.Option(help="robot id (default: the scene's robot)")] = None,
    n_episodes: Annotated[int | None, typer.Option(help="episodes to record (default: the scene's)")] = None,
    seed: Annotated[int | None, typer.Option(help="seed of the first episode; episode k uses seed+k")] = None,
    max_steps: Annotated[int | None, typer.Option(help="step limit per episode (default: the task's)")] = None,
    out: Annotated[Path | None, typer.Option(help="output folder (default: a new folder under datasets/)")] = None,
    codec: Annotated[CodecChoice, typer.Option(help="video codec")] = CodecChoice.av1,
) -> None:
    """Record episodes of SCENE driven by RSKILL into a LeRobotDataset v3."""
    from openral_data.record import RecordOptions
    from openral_data.record import record as run_record

    opts = RecordOptions(
        scene=scene, rskill=rskill, robot=robot, n_episodes=n_episodes, seed=seed, max_steps=max_steps,
        out=out, codec=codec.value,
    )
    with Progress(
        TextColumn("[bold]recording"), BarColumn(), MofNCompleteColumn(), TextColumn("episodes"),
        TextColumn("{task.fields[frames]} frames"), TimeElapsedColumn(), console=err_console,
        disable=not err_console.is_terminal,
    ) as bar:
        task = bar.add_task("record", total=n_episodes, frames=0)

        def progress(rec: object, frames: int) -> None:
            bar.update(task, advance=1, frames=frames)

        summary = run_record(opts, progress)
    table = Table(title="recorded", show_header=False)
    table.add_row("output", str(summary.out))
    table.add_row("episodes", str(len(summary.episodes)))
    table.add_row("success rate", f"{summary.success_rate:.1%}")
    table.add_row("frames", str(summary.frames))
    table.add_row("frames/s", f"{summary.fps:.1f}")
    table.add_row("codec", codec.value)
    console.print(table)


@app.command()
def info(dataset: Annotated[Path, typer.Argument(help="a LeRobot v3 dataset folder")]) -> None:
    """Print a dataset's summary: episodes, frames, tasks, cameras, success rate."""
    from openral_data.sinks.lerobot_v3 import summarize

    s = summarize(dataset)
    table = Table(title=str(dataset), show_header=False)
    table.add_row("episodes", str(s.episodes))
    table.add_row("frames", str(s.frames))
    table.add_row("fps", str(s.fps))
    table.add_row("duration", f"{s.frames / s.fps:.1f} s")
    table.add_row("cameras", ", ".join(s.cameras) or "-")
    table.add_row("tasks", "; ".join(s.tasks) or "-")
    table.add_row("robot", s.robot_type or "-")
    rate = s.success_rate
    table.add_row("success rate", "-" if rate is None else f"{rate:.1%} ({s.successes}/{s.episodes})")
    console.print(table)


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
                    rid, rs.policy, ",".join(rs.embodiment_tags),
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
                    rid, ",".join(rb.embodiment_tags), str(len(rb.joints)), str(rb.observation.state.dim),
                    str(rb.action.dim), ",".join(c.name for c in rb.sensors.cameras) or "-",
                )
            except OpenralError as exc:
                table.add_row(rid, "[red]invalid", str(exc), "", "", "")
    console.print(table)


def main() -> None:
    try:
        app(standalone_mode=False)
    except OpenralError as exc:
        err_console.print(f"error: {exc}", markup=False, highlight=False, soft_wrap=True)
        sys.exit(2)
    except KeyboardInterrupt:
        err_console.print("interrupted: finished episodes are kept", markup=False)
        sys.exit(130)
    except typer.Exit as exc:
        sys.exit(exc.exit_code)
    except Exception as exc:  # click usage errors
        import click

        if isinstance(exc, click.ClickException):
            exc.show()
            sys.exit(exc.exit_code)
        if isinstance(exc, click.exceptions.Abort):
            sys.exit(130)
        raise


if __name__ == "__main__":
    main()
