"""`openral-data info | list | view | doctor`: look at datasets and at what this installation knows."""

from __future__ import annotations

import os
import time
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich import box
from rich.console import Console
from rich.markup import escape
from rich.table import Table
from rich.text import Text

from openral_data import paths
from openral_data.cli.fit import cut_to_fit
from openral_data.cli.jsonout import JsonFlag, print_json
from openral_data.cli.takes import takes
from openral_data.cli.terminal import console, print_line, print_rows
from openral_data.errors import OpenralError, UsageError
from openral_data.formats.repo_id import resolve_dataset

if TYPE_CHECKING:
    from openral_data.convert.kinds.base import Description
    from openral_data.runtime.catalog import Item


class ListWhat(StrEnum):
    all = "all"
    scenes = "scenes"
    rskills = "rskills"
    robots = "robots"
    types = "types"
    policies = "policies"
    tasks = "tasks"


@takes("dataset", pixels=False, v2="in place")
def info(
    dataset: Annotated[
        Path,
        typer.Argument(
            help="a LeRobot dataset folder, a bag (.bag, .mcap, rosbag2 folder, folder of bags), a zarr replay "
            "buffer (.zarr folder or .zarr.zip) or an RLDS/TFDS build folder"
        ),
    ],
    json: JsonFlag = False,
) -> None:
    """Print a dataset's summary: episodes, frames, tasks, cameras, success rate; for a bag its topics, types,
    counts and rates; for a zarr replay buffer or RLDS folder its episodes, steps and arrays."""
    from openral_data.formats.lerobot_v3 import layout

    dataset = resolve_dataset(dataset)
    if (dataset / layout.INFO_PATH).is_file():  # a LeRobot dataset of any version: no convert stack to start
        from openral_data.metrics.dataset_info import describe_dataset

        about: Description = describe_dataset(dataset)
    else:
        from openral_data.convert.entry import describe

        about = describe(dataset)  # the source registry's kind of it (a LeRobot dataset when none takes it)
    if json:
        print_json("info", about.to_json())
        return
    print_rows(str(dataset), about.rows())


def list_cmd(
    what: Annotated[ListWhat, typer.Argument(help="what to list (default: everything)", metavar="[WHAT]")] = (
        ListWhat.all
    ),
    scene: Annotated[str | None, typer.Argument(help="list tasks: the scene (id or YAML path)")] = None,
    show_paths: Annotated[bool, typer.Option("--paths", help="also show each manifest's file")] = False,
    all_: Annotated[bool, typer.Option("--all", help="also the benchmark copies (`*_bench`) and every column")] = False,
    json: JsonFlag = False,
) -> None:
    """List the scenes, rSkills, robots, scene types and policies this installation knows, and where each comes
    from (built-in, plug-in, user, project, --*-dir); a broken plug-in is reported on one line, never fatal.
    `list tasks SCENE` lists the tasks of a suite scene (`record --task`). A scene or rSkill that cannot run in
    this environment says why in its `runs here` column (a simulator extra missing, a checkpoint absent). The
    tables fit the terminal: the main columns, without the scenes' benchmark copies (`--all` shows them and every
    column); a cell too wide is cut with `…` (`--json` has everything)."""
    if what is ListWhat.tasks:
        _list_tasks(scene, json)
        return
    if scene is not None:
        raise UsageError(f"list {what.value}: takes no SCENE (only `list tasks SCENE` does)")
    from openral_data.runtime.catalog import SECTIONS, catalog

    sections = SECTIONS if what is ListWhat.all else (_SECTION[what],)
    cat = catalog(sections)
    for problem in cat.plugin_problems:
        print_line("warning: " + problem.line(), err=True)
    if json:
        print_json("list", cat.to_json())
        return
    out = console if console.is_terminal else _piped()
    for name, items in cat.sections.items():
        out.print(name.replace("_", " "), style="bold", markup=False, highlight=False)  # unpadded, unlike a title
        shown_items = items if all_ else [it for it in items if it.fields.get("tier") != "benchmark"]
        notes: list[str] = []  # why an entry cannot run here, each reason once
        table = _table(name, shown_items, notes, show_paths=show_paths, every_column=all_)
        cut = cut_to_fit(out, table, out.width, whole=("path",))  # a path asked for is never cut
        if cut is None:  # too narrow even with cut cells: one record per entry, so no cell wraps mid-word
            _print_records(out, table)
        else:
            out.print(table)
        for line in _notes(name, items, notes, all_, cut=cut is True, width=out.width):
            out.print(line, markup=False, highlight=False)


def _notes(name: str, items: list[Item], notes: list[str], all_: bool, *, cut: bool, width: int) -> list[str]:
    """The lines under a section: why entries cannot run here, what `--all` would add, that cells were cut."""
    lines = [f"({i}) {note}" for i, note in enumerate(notes, 1)]
    hidden = [c for c in _columns(name, every_column=True) if c not in _columns(name, every_column=False)]
    bench = sum(it.fields.get("tier") == "benchmark" for it in items)
    if not all_ and (bench or hidden):
        more = [f"{bench} benchmark copies (*_bench)"] if bench else []
        more += [f"the column{'s' if len(hidden) > 1 else ''} {', '.join(t for t, _ in hidden)}"] if hidden else []
        lines.append(f"(--all: also {' and '.join(more)})")
    if cut:
        lines.append(f"(… : a cell cut to fit {width} columns; --json shows every cell whole)")
    return lines


def _print_records(out: Console, table: Table) -> None:
    """`table` as records: each entry's id on a line, then one `column  value` line per cell (markup as text)."""
    heads = [str(c.header) for c in table.columns]
    cells = [[Text.from_markup(str(v)).plain for v in c.cells] for c in table.columns]
    pad = max(len(h) for h in heads[1:]) if len(heads) > 1 else 0
    for i in range(table.row_count):
        out.print(cells[0][i], markup=False, highlight=False)
        for h, col in zip(heads[1:], cells[1:], strict=True):
            if col[i]:
                out.print(f"  {h:<{pad}}  {col[i]}", markup=False, highlight=False)


def _piped() -> Console:
    """Piped or redirected: no terminal width to fit, so a cell is never cut (ids, tags and paths stay greppable),
    unless `$COLUMNS` asks for a width."""
    return Console(width=int(os.environ.get("COLUMNS") or 1000), color_system=None)


def _list_tasks(scene_ref: str | None, json: bool) -> None:
    from openral_data.runtime.tasks import tasks_of

    if scene_ref is None:
        raise UsageError("list tasks: needs SCENE (a scene id or YAML path), e.g. `list tasks metaworld_push`")
    scene, found = tasks_of(scene_ref)
    if json:
        items = [{"id": t.id, "instruction": t.instruction, "aliases": list(t.aliases)} for t in found]
        print_json("list", {"scene": scene.scene.id, "tasks": items})
        return
    table = Table(title=f"tasks of {escape(scene.scene.id)} ({escape(scene.scene.type)})")
    for col in ("id", "also", "instruction"):
        table.add_column(col)
    for t in found:
        table.add_row(escape(t.id), escape(",".join(t.aliases)), escape(t.instruction))
    (console if console.is_terminal else _piped()).print(table)


_SECTION = {
    ListWhat.scenes: "scenes",
    ListWhat.rskills: "rskills",
    ListWhat.robots: "robots",
    ListWhat.types: "scene_types",
    ListWhat.policies: "policies",
}
# columns whose title is not the field's name (several fields may share a column, space-separated)
_TITLES = {
    "default_rskill": "default rSkill",
    "embodiment_tags": "embodiment",
    "state_dim": "state",
    "action_dim": "action",
}
_JOINED = {"state_dim": "state_representation", "action_dim": "action_representation"}  # with --all
# the columns `list` shows without --all (the others: --all; --json has every field)
_MAIN = {
    "scenes": ("robot", "default_rskill"),
    "rskills": ("policy", "embodiment_tags", "state_dim", "action_dim"),
    "robots": ("embodiment_tags", "joints", "scenes"),
}


def _columns(name: str, *, every_column: bool) -> list[tuple[str, str]]:
    """A section's (title, field) columns after the id."""
    from openral_data.runtime.catalog import FIELDS

    joined = set(_JOINED.values())
    keys = [k for k in FIELDS[name] if k not in joined and (every_column or k in _MAIN.get(name, FIELDS[name]))]
    return [(_TITLES.get(key, key), key) for key in keys]


def _table(name: str, items: list[Item], notes: list[str], *, show_paths: bool, every_column: bool) -> Table:
    """One section: ids never cut (the widest id sets the column), `from` only when something is not built in,
    `runs here` yes/no with the reasons numbered in `notes`, the path (with `--paths`) last."""
    columns = _columns(name, every_column=every_column)
    with_path = show_paths and name in ("scenes", "rskills", "robots")
    with_from = any(it.origin != "built-in" or it.overrides for it in items)
    table = Table(box=box.SIMPLE_HEAD, show_edge=False, pad_edge=False, padding=(0, 1, 0, 0))
    table.add_column("id", no_wrap=True, min_width=max((len(it.id) for it in items), default=2))
    for col in (*(c for c, _ in columns), *(("from",) if with_from else ())):
        table.add_column(col, overflow="fold")
    if name in ("scenes", "rskills"):
        table.add_column("runs here", no_wrap=True)
    if with_path:
        table.add_column("path", overflow="fold")
    for it in items:
        origin = it.origin + (f" (overrides {', '.join(it.overrides)})" if it.overrides else "")
        if it.error is not None:
            cells = ["[red]invalid: " + escape(it.error), *("" for _ in columns[1:])] if columns else []
        else:
            joined = _JOINED if every_column else {}
            cells = [" ".join(_cell(it.fields.get(k)) for k in (key, joined.get(key)) if k) for _, key in columns]
        row = [escape(it.id), *cells, *((escape(origin),) if with_from else ())]
        if name in ("scenes", "rskills"):
            row.append(_runs_here(name, it, notes))
        table.add_row(*row, *((escape(it.path or ""),) if with_path else ()))
    return table


def _runs_here(section: str, it: Item, notes: list[str]) -> str:
    """`yes`, or `no (n)` with note n saying why (a simulator extra missing, a neural rSkill's checkpoint absent)."""
    from openral_data.runtime import available, registry

    if it.error is not None:
        return "no"
    if section == "scenes":
        kind = str(it.fields.get("type"))
        problem = available.scene_type_problem(kind)
        problem = None if problem is None else f"{kind} scenes: {problem}"
    elif not available.needs_checkpoint(str(it.fields.get("policy"))):
        problem = None  # (its manifest loaded: the catalog has its fields)
    else:
        try:
            problem = available.rskill_problem(registry.resolve_rskill(it.path or it.id)[0])
        except OpenralError as exc:
            problem = str(exc)
    if problem is None:
        return "yes"
    if problem not in notes:
        notes.append(problem)
    return f"[yellow]no ({notes.index(problem) + 1})"


def _cell(value: object) -> str:
    if value is None:
        return "-"
    if isinstance(value, list):
        return ",".join(str(v) for v in value) or "-"
    return escape(str(value))


@takes("path", pixels=True, v2="in place")
def view(
    path: Annotated[Path, typer.Argument(help="a LeRobot v3 dataset folder or an .mcap file")],
    episode: Annotated[int, typer.Option(help="episode index")] = 0,
    save: Annotated[Path | None, typer.Option(help="write this .rrd instead of opening a viewer")] = None,
    results: Annotated[Path | None, typer.Option(help="replay/eval results directory: log divergence")] = None,
    serve: Annotated[
        bool, typer.Option("--serve", help="keep the episode in rerun's web viewer, served until Ctrl-C")
    ] = False,
    web_port: Annotated[int, typer.Option(help="--serve: the web viewer's HTTP port")] = 9090,
    grpc_port: Annotated[int, typer.Option(help="--serve: the port of the stream the viewer reads")] = 9876,
) -> None:
    """Show an episode in rerun: videos, named state/action series, task, success/done, replay divergence."""
    # rerun's own log lines (on stderr) would come on top of our one-line error; what it fails on, we report
    os.environ.setdefault("RUST_LOG", "off")
    path = resolve_dataset(path)
    if serve:
        _serve(path, episode, save, results, web_port, grpc_port)
        return
    from openral_data.viz.rerun_view import ViewOptions, run_view

    if save is not None:
        paths.check_file_output(save, "--save")
    print_line(run_view(ViewOptions(path, episode, save, results)))


def _serve(path: Path, episode: int, save: Path | None, results: Path | None, web_port: int, grpc_port: int) -> None:
    """`view --serve`: serve the episode in rerun's web viewer until Ctrl-C (exit 130, as every command)."""
    if save is not None:
        raise UsageError("--serve: serves the episode; --save writes it to a file: give one of them")
    from openral_data.viz.serve import serve_episode

    served = serve_episode(path, episode, results, web_port, grpc_port)
    print_line(f"view: serving {path} episode {episode} ({served.frames} frames) at {served.url} (Ctrl-C stops)")
    while True:  # rerun serves from its own threads; this process only has to stay alive
        time.sleep(3600)


@takes("dataset", pixels=True, v2="in place")
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
    from openral_data.runtime.catalog import plugin_problems

    for problem in plugin_problems():  # a broken plug-in is worth knowing about whatever is checked
        print_line("warning: " + problem.line(), err=True)
    report = doctor_report(resolve_dataset(dataset), repair, deep)
    if json:
        print_json("doctor", report.to_json())
    else:
        print_line(report.text())
    if report.exit_code:
        raise typer.Exit(report.exit_code)
