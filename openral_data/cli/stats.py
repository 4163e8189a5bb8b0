"""`openral-data stats`: the report of openral_data.metrics, printed as a terminal table, JSON, CSV or Markdown."""

from __future__ import annotations

from collections.abc import Sequence
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from openral_data import paths as paths_
from openral_data.cli.defaultgroup import DefaultCommandGroup
from openral_data.cli.edit import report
from openral_data.cli.jsonout import JsonFlag, print_json
from openral_data.cli.tables import render_tables
from openral_data.cli.takes import takes
from openral_data.formats.repo_id import resolve_dataset
from openral_data.text import printable

if TYPE_CHECKING:
    from openral_data.metrics.command import StatsOptions
    from openral_data.metrics.report import Table


class StatsFormat(StrEnum):
    table = "table"
    json = "json"
    csv = "csv"
    markdown = "markdown"


stats_app = typer.Typer(
    cls=DefaultCommandGroup,
    no_args_is_help=True,
    help="Statistics of datasets and results: `stats PATH…` (the same as `stats report PATH…`) prints the report "
    "of episodes, frames and success rates computed by DuckDB; `stats recompute DATASET` rewrites a dataset's "
    "feature statistics. A dataset folder named `report` or `recompute` is given as `./report`, `./recompute`.",
)


@stats_app.command("report")
@takes("paths", pixels=False, v2="in place")
def stats(
    paths: Annotated[list[str], typer.Argument(help="datasets and/or results directories (globs allowed)")],
    by: Annotated[str | None, typer.Option(help="group by: dataset,task,rskill,scene,robot,seed")] = None,
    sql: Annotated[str | None, typer.Option(help="run this SQL on the views instead of the report")] = None,
    fmt: Annotated[
        StatsFormat, typer.Option("--format", help="output format (json: one line, as --json)")
    ] = StatsFormat.table,
    plot: Annotated[Path | None, typer.Option(help="also write a PNG: success rates + action histograms")] = None,
    memory_limit: Annotated[str, typer.Option(help="DuckDB memory limit")] = "1GB",
    health: Annotated[bool, typer.Option(help="run the health checks")] = True,
    trust_episode_stats: Annotated[
        bool,
        typer.Option(help="summarise a dataset without our digests (e.g. lerobot's) from its per-episode stats"),
    ] = False,
    full_scan: Annotated[
        bool, typer.Option(help="summarise the frames even where verified per-episode stats could stand for them")
    ] = False,
    reference: Annotated[
        str | None,
        typer.Option(help="compare the other groups with this one (default: the first dataset given)", metavar="GROUP"),
    ] = None,
    all_: Annotated[
        bool, typer.Option("--all", help="every table and column (default: groups, success, interval)")
    ] = False,
    json: JsonFlag = False,
) -> None:
    """Episodes, frames, success rates with 95 % intervals, comparisons and health, computed by DuckDB.

    `stats PATH…` is `stats report PATH…`. `stats recompute DATASET` rewrites a dataset's statistics.

    A dataset folder named `report` or `recompute` is given as `./report`, `./recompute`."""
    from openral_data.metrics.command import StatsOptions
    from openral_data.paths import check_file_output

    if plot is not None:
        check_file_output(plot, "--plot")
    paths = [str(resolve_dataset(p)) for p in paths]  # a repo id is its cached folder; globs stay globs
    fmt = StatsFormat.json if json else fmt
    opts = StatsOptions(
        paths, by, sql, fmt.value, plot, memory_limit, health, trust_episode_stats, full_scan, reference=reference
    )
    if fmt is StatsFormat.json:  # one line with `command` and `version`, like every `--json`
        from openral_data.metrics.command import stats_tables
        from openral_data.metrics.render import json_payload

        print_json("stats", json_payload(stats_tables(opts)))
        return
    print(stats_text(opts, full=all_))


@stats_app.command("recompute")
@takes("dataset", pixels=True, v2="upgrade", writes="new or in place")
def recompute_cmd(
    dataset: Annotated[Path, typer.Argument(help="a LeRobot v3 dataset (ours or lerobot's)")],
    out: Annotated[Path | None, typer.Option(help="new dataset folder (must not exist or be empty)")] = None,
    in_place: Annotated[bool, typer.Option(help="replace DATASET itself (swapped in once complete)")] = False,
) -> None:
    """Write DATASET with every feature's statistics recomputed (numbers from rows, cameras from decoded pixels)."""
    from openral_data.edit.stats import recompute

    if out is not None:
        paths_.check_creatable(out, "--out")
    report("recomputed", [recompute(resolve_dataset(dataset), out, in_place)])


def stats_text(opts: StatsOptions, *, full: bool = False) -> str:
    """What `stats` prints: the tables in `opts.fmt` (a terminal table: the compact view unless `full`, see
    cli/tables.py), dataset text (tasks, SQL results) with control characters escaped (JSON escapes its own)."""
    from openral_data.metrics.command import stats_tables
    from openral_data.metrics.render import render

    tables = stats_tables(opts)
    if opts.fmt != "table":
        return printable(render(tables, opts.fmt), keep_newlines=True)
    return render_tables(tables, compact=not full and opts.sql is None)


def render_table(tables: Sequence[Table]) -> str:
    """Every table and column, as wide as the terminal (vertical records where a table is wider)."""
    return render_tables(tables)
