"""`openral-data quality DATASET…`: compute (or reuse) each dataset's episode quality table and print the counts
of flagged episodes and the flagged episodes themselves (docs/stats.md, "Quality")."""

from __future__ import annotations

import functools
from typing import Annotated

import typer

from openral_data.cli.legacy import upgraded
from openral_data.cli.stats import StatsFormat, render_table
from openral_data.cli.takes import takes
from openral_data.cli.terminal import print_line, progress_bar
from openral_data.errors import UsageError
from openral_data.formats.repo_id import resolve_dataset
from openral_data.text import printable

DETAIL = ("episode_index", "flags", "idle_fraction", "idle_head", "idle_tail", "ldlj", "gripper_toggles_per_s")


@takes("paths", pixels=True, v2="upgrade")
def quality(
    paths: Annotated[list[str], typer.Argument(help="LeRobot v3 datasets (ours or lerobot's; globs allowed)")],
    stride: Annotated[
        int | None,
        typer.Option(help="measure every N-th frame of each camera (all are decoded); default 5, or the cached one's"),
    ] = None,
    recompute: Annotated[bool, typer.Option(help="compute even when a current cached table exists")] = False,
    threshold: Annotated[
        list[str] | None,
        typer.Option(help="NAME=VALUE: a quality threshold other than its default (repeatable; docs/stats.md)"),
    ] = None,
    all_episodes: Annotated[bool, typer.Option("--all", help="list every episode, not only flagged ones")] = False,
    fmt: Annotated[StatsFormat, typer.Option("--format", help="output format")] = StatsFormat.table,
) -> None:
    """Score every episode: idle time, frozen dimensions, jerk, gripper chatter, clipping, timestamp jitter and
    gaps, camera black/saturated/frozen/blurred frames, each with a flag. Cached (DATASET/.openral/ or the user
    cache) and recomputed only when the data changed; `stats --sql` and `episodes filter --where` see it as
    the `quality` view."""
    from openral_data.metrics.quality import counts_table, parse_thresholds, quality_of
    from openral_data.metrics.render import render
    from openral_data.metrics.report import Table
    from openral_data.metrics.sources import resolve

    if stride is not None and stride < 1:
        raise UsageError(f"--stride: {stride}; give 1 or more")
    th = parse_thresholds(threshold or [])
    datasets, results = resolve([str(resolve_dataset(p)) for p in paths])
    if results or not datasets:
        raise UsageError("quality: give LeRobot v3 datasets (not results directories)")
    detail = Table("episodes", ["dataset", *DETAIL])
    for ds in datasets:
        with progress_bar(f"quality {printable(ds.label)}", "episodes") as bar:
            advance = functools.partial(bar.advance, bar.add_task("", total=int(ds.info.get("total_episodes", 0))))
            q = quality_of(ds, stride, th, recompute=recompute, progress=advance)
        print_line(f"quality: {'computed' if q.computed else 'cached'}: {q.paths.episodes.parent}", err=True)
        source = upgraded(ds.root)  # a v2.x dataset's temporary upgrade: its episodes as the user numbers them
        for row in q.table.select([*DETAIL, "flagged"]).to_pylist():
            if source is not None:
                row["episode_index"] = source.numbers[row["episode_index"]]
            if all_episodes or row["flagged"]:
                detail.rows.append([ds.label, *(row[c] for c in DETAIL)])
    tables = [counts_table(datasets, th), detail]
    print(
        render_table(tables) if fmt == StatsFormat.table else printable(render(tables, fmt.value), keep_newlines=True)
    )
