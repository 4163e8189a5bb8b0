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
from rich.measure import Measurement
from rich.table import Table
from rich.text import Text

from openral_data import paths
from openral_data.cli.jsonout import JsonFlag, print_json
from openral_data.cli.terminal import console, print_line, print_rows
from openral_data.errors import OpenralError, UsageError
from openral_data.formats.repo_id import resolve_dataset

if TYPE_CHECKING:
    from openral_data.formats.lerobot_v3 import DatasetSummary
    from openral_data.runtime.catalog import Item


class ListWhat(StrEnum):
    all = "all"
    scenes = "scenes"
    rskills = "rskills"
    robots = "robots"
    types = "types"
    policies = "policies"
    tasks = "tasks"


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
    from openral_data.convert.to_mcap import is_lerobot_dataset
    from openral_data.formats.dataset import summarize
    from openral_data.formats.lerobot_v3.reader import LEGACY_VERSIONS as legacy

    dataset = resolve_dataset(dataset)
    if not is_lerobot_dataset(dataset) and _source_info(dataset, json):
        return
    s = summarize(dataset)
    counts = _quality_counts(dataset)
    if json:
        print_json("info", {**s.to_json(), "quality": counts})
        return
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
            ("success rate", _success_cell(s)),
            *([("format", f"LeRobot {s.codebase_version} (read in place)")] if s.codebase_version in legacy else []),
            *([("missing", line.removeprefix("missing: "))] if s.missing and (line := s.missing.line()) else []),
            ("quality", _quality_cell(counts)),
        ],
    )


def _source_info(src: Path, json: bool) -> bool:
    """`info` of a bag or an episodic array source (False: `src` is neither, so it is read as a dataset)."""
    from openral_data.convert.array_sources import detect_array_source
    from openral_data.convert.discover import describe_arrays, describe_bags, is_bag_source

    if is_bag_source(src):
        bags = describe_bags(src)
        if json:
            print_json("info", bags.to_json())
            return True
        rows = [("bags", str(len(bags.bags))), ("duration", f"{bags.duration:.2f} s")]
        for t in bags.topics.values():
            rate = f"{t.rate:.2f} Hz" if t.rate is not None else "-"
            rows.append((t.topic, f"{t.msgtype}, {t.messages} msgs, {rate}"))
        print_rows(str(src), rows)
        return True
    source = detect_array_source(src)
    if source is None:
        return False
    arrays = describe_arrays(source)
    if json:
        print_json("info", arrays.to_json())
        return True
    fps = f"{arrays.fps:g}" if arrays.fps is not None else "not stored (convert --fps N or the mapping)"
    languages = "; ".join(arrays.languages[:5]) + (
        f" (+{len(arrays.languages) - 5} more)" if len(arrays.languages) > 5 else ""
    )
    rows = [("layout", arrays.layout), ("episodes", str(arrays.episodes)), ("steps", str(arrays.steps)), ("fps", fps)]
    rows += [
        (a.key, f"{a.dtype} {list(a.shape)}" + ("" if a.encoding == "raw" else f" ({a.encoding})"))
        for a in arrays.arrays
    ]
    rows += [(key, f"ignored: {why}") for key, why in arrays.ignored.items()]
    rows.append(("tasks", languages or "-"))
    print_rows(str(src), rows)
    return True


def _quality_counts(dataset: Path) -> dict[str, int] | None:
    """Episodes flagged per quality flag (and `flagged`, `episodes`) from the current cached table, else None."""
    from openral_data.metrics.quality import flag_counts
    from openral_data.metrics.sources import open_dataset

    try:
        return flag_counts(open_dataset(dataset))
    except OpenralError:
        return None


def _quality_cell(counts: dict[str, int] | None) -> str:
    """`2 of 8 episodes flagged (idle 1, camera_black 1)` (`_quality_counts`), else how to get one."""
    if counts is None:
        return "not computed (openral-data quality DATASET)"
    raised = ", ".join(f"{k} {v}" for k, v in counts.items() if v and k not in ("episodes", "flagged"))
    return f"{counts['flagged']} of {counts['episodes']} episodes flagged" + (f" ({raised})" if raised else "")


def _success_cell(s: DatasetSummary) -> str:
    """`50.0% (1/2)` over the episodes whose success is known (and how many are not), `unknown (N episodes)` when
    none is (never 0 %)."""
    if s.success_rate is None:
        return f"unknown ({s.episodes} episode{'' if s.episodes == 1 else 's'})"
    unknown = s.episodes - s.success_known
    return f"{s.success_rate:.1%} ({s.successes}/{s.success_known}" + (f", {unknown} unknown)" if unknown else ")")


def list_cmd(
    what: Annotated[ListWhat, typer.Argument(help="what to list (default: everything)")] = ListWhat.all,
    scene: Annotated[str | None, typer.Argument(help="list tasks: the scene (id or YAML path)")] = None,
    show_paths: Annotated[bool, typer.Option("--paths", help="also show each manifest's file")] = False,
    json: JsonFlag = False,
) -> None:
    """List the scenes, rSkills, robots, scene types and policies this installation knows, and where each comes
    from (built-in, plug-in, user, project, --*-dir); a broken plug-in is reported on one line, never fatal.
    `list tasks SCENE` lists the tasks of a suite scene (`record --task`). A scene or rSkill that cannot run in
    this environment says why in its `runs here` column (a simulator extra missing, a checkpoint absent)."""
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
        table = _table(name, items, show_paths)
        if Measurement.get(out, out.options.update_width(10_000), table).maximum <= out.width:
            out.print(table)
        else:  # too narrow for the grid: one record per entry, so no cell wraps mid-word
            _print_records(out, table)


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
    if table.caption:
        out.print(Text.from_markup(str(table.caption)).plain, markup=False, highlight=False)


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
_JOINED = {"state_dim": "state_representation", "action_dim": "action_representation"}


def _table(name: str, items: list[Item], show_paths: bool) -> Table:
    """One section: ids never cut (the widest id sets the column), `from` only when something is not built in,
    `runs here` yes/no with the reasons as numbered notes under the table, the path (with `--paths`) last."""
    from openral_data.runtime.catalog import FIELDS

    joined = set(_JOINED.values())
    columns = [(_TITLES.get(key, key), key) for key in FIELDS[name] if key not in joined]
    with_path = show_paths and name in ("scenes", "rskills", "robots")
    with_from = any(it.origin != "built-in" or it.overrides for it in items)
    notes: list[str] = []  # why an entry cannot run here, each reason once
    table = Table(box=box.SIMPLE_HEAD, pad_edge=False, caption_justify="left")
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
            cells = [" ".join(_cell(it.fields.get(k)) for k in (key, _JOINED.get(key)) if k) for _, key in columns]
        row = [escape(it.id), *cells, *((escape(origin),) if with_from else ())]
        if name in ("scenes", "rskills"):
            row.append(_runs_here(name, it, notes))
        table.add_row(*row, *((escape(it.path or ""),) if with_path else ()))
    table.caption = "\n".join(f"({i}) {escape(note)}" for i, note in enumerate(notes, 1)) or None
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
