"""`openral-data info | list | view | doctor`: look at datasets and at what this checkout knows."""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

from openral_data import paths
from openral_data.cli.jsonout import JsonFlag, print_json
from openral_data.cli.terminal import console, print_line, print_rows
from openral_data.errors import OpenralError
from openral_data.record import registry


class ListWhat(StrEnum):
    scenes = "scenes"
    rskills = "rskills"
    robots = "robots"


def info(dataset: Annotated[Path, typer.Argument(help="a LeRobot v3 dataset folder")], json: JsonFlag = False) -> None:
    """Print a dataset's summary: episodes, frames, tasks, cameras, success rate."""
    from openral_data.formats.lerobot_v3 import summarize

    s = summarize(dataset)
    if json:
        print_json("info", s.to_json())
        return
    rate = s.success_rate
    print_rows(
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


def list_cmd(what: Annotated[ListWhat, typer.Argument(help="scenes, rskills or robots")] = ListWhat.scenes) -> None:
    """List the scenes, rSkills or robots this checkout knows."""
    table = {ListWhat.scenes: _scenes, ListWhat.rskills: _rskills, ListWhat.robots: _robots}[what]()
    # piped or redirected: no terminal width to fit, so never cut a cell (ids, tags and paths stay greppable)
    (console if console.is_terminal else Console(width=1000, color_system=None)).print(table)


def _scenes() -> Table:
    from openral_data.schemas.scene import load_scene

    table = Table()
    for col in ("id", "tier", "type", "robot", "path"):
        table.add_column(col)
    for sid, path in registry.scene_files().items():
        try:
            sc = load_scene(path)
            table.add_row(sid, sc.tier, sc.scene.type, sc.scene.robot or "-", str(path))
        except OpenralError as exc:
            table.add_row(sid, "[red]invalid", str(exc), "", str(path))
    table.add_row("", "", f"types: {', '.join(sorted(registry.SCENES))}", "", "")
    return table


def _rskills() -> Table:
    from openral_data.schemas.base import load_model
    from openral_data.schemas.rskill import RSkillManifest

    table = Table()
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
    return table


def _robots() -> Table:
    table = Table()
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
    return table


def view(
    path: Annotated[Path, typer.Argument(help="a LeRobot v3 dataset folder or an .mcap file")],
    episode: Annotated[int, typer.Option(help="episode index")] = 0,
    save: Annotated[Path | None, typer.Option(help="write this .rrd instead of opening a viewer")] = None,
    results: Annotated[Path | None, typer.Option(help="replay/eval results directory: log divergence")] = None,
) -> None:
    """Show an episode in rerun: videos, named state/action series, task, success/done, replay divergence."""
    from openral_data.viz.rerun_view import ViewOptions, run_view

    if save is not None:
        paths.check_creatable(save, "--save", folder=False)
    print_line(run_view(ViewOptions(path, episode, save, results)))


def doctor(
    dataset: Annotated[Path, typer.Argument(help="a LeRobot v3 dataset folder (ours or lerobot's)")],
    repair: Annotated[bool, typer.Option("--repair", help="fix what is safely fixable (originals are kept)")] = False,
    deep: Annotated[
        bool, typer.Option("--deep", help="also decode every frame and compare it with the stored image statistics")
    ] = False,
    json: JsonFlag = False,
) -> None:
    """Check a dataset against lerobot 0.6.1's format rules, one line per finding; exit 1 on errors."""
    from openral_data.doctor.command import doctor_report

    report = doctor_report(dataset, repair, deep)
    if json:
        print_json("doctor", report.to_json())
    else:
        print_line(report.text())
    if report.exit_code:
        raise typer.Exit(report.exit_code)
