"""`openral-data quality DATASET…`: compute (or reuse) each dataset's episode quality table and print the counts
of flagged episodes and the flagged episodes themselves, or one episode's findings (`--episode N`: each check,
its dimension or camera, its frames, the value against its threshold) (docs/stats.md, "Quality")."""

from __future__ import annotations

import functools
import math
from typing import Annotated, Any

import typer

from openral_data.cli.legacy import upgraded
from openral_data.cli.stats import StatsFormat, render_table
from openral_data.cli.takes import takes
from openral_data.cli.terminal import print_line, progress_bar
from openral_data.errors import UsageError
from openral_data.formats.repo_id import resolve_dataset
from openral_data.text import printable

DETAIL = ("episode_index", "flags", "idle_fraction", "idle_head", "idle_tail", "ldlj", "gripper_toggles_per_s")
SPANS_SHOWN = 3  # frame spans of the flagging findings in the episodes table's `frames` cell


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
    episode: Annotated[
        int | None, typer.Option(help="print this episode's findings: check, dimension or camera, frames, value")
    ] = None,
    all_episodes: Annotated[bool, typer.Option("--all", help="list every episode, not only flagged ones")] = False,
    fmt: Annotated[StatsFormat, typer.Option("--format", help="output format")] = StatsFormat.table,
) -> None:
    """Score every episode: idle time, frozen dimensions, jerk, gripper chatter, clipping, timestamp jitter and
    gaps, camera black/saturated/frozen/blurred frames, each with a flag and the findings that raised it (which
    dimension or camera, which frames). Cached (DATASET/.openral/ or the user cache) and recomputed only when the
    data changed; `stats --sql` and `episodes filter --where` see it as the `quality` and `quality_findings`
    views."""
    from openral_data.metrics.quality import parse_thresholds, quality_of
    from openral_data.metrics.sources import resolve

    if stride is not None and stride < 1:
        raise UsageError(f"--stride: {stride}; give 1 or more")
    th = parse_thresholds(threshold or [])
    datasets, results = resolve([str(resolve_dataset(p)) for p in paths])
    if results or not datasets:
        raise UsageError("quality: give LeRobot v3 datasets (not results directories)")
    if episode is not None and len(datasets) != 1:
        raise UsageError(f"--episode: give one dataset (got {len(datasets)})")
    computed = []
    for ds in datasets:
        with progress_bar(f"quality {printable(ds.label)}", "episodes") as bar:
            advance = functools.partial(bar.advance, bar.add_task("", total=int(ds.info.get("total_episodes", 0))))
            q = quality_of(ds, stride, th, recompute=recompute, progress=advance)
        print_line(f"quality: {'computed' if q.computed else 'cached'}: {q.paths.episodes.parent}", err=True)
        computed.append((ds, q))
    if episode is not None:
        tables = [_episode_findings(*computed[0], episode)]
    else:
        tables = _summary(computed, th, all_episodes, compact=fmt == StatsFormat.table)
    _print(tables, fmt)


def _print(tables: list[Any], fmt: StatsFormat) -> None:
    from openral_data.metrics.render import render

    if fmt != StatsFormat.table:
        print(printable(render(tables, fmt.value), keep_newlines=True))
        return
    none_flagged = [t for t in tables if t.name == "episodes" and not t.rows]  # a line, not an empty grid
    print(render_table([t for t in tables if t not in none_flagged]))
    if none_flagged:
        print("episodes: none flagged (--all lists every episode)")


def _numbering(ds: Any) -> list[int] | None:
    """A v2.x dataset's temporary upgrade: its episodes as the user numbers them (by upgraded index)."""
    source = upgraded(ds.root)
    return None if source is None else list(source.numbers)


def _summary(computed: list[Any], th: Any, all_episodes: bool, *, compact: bool) -> list[Any]:
    """The counts of flagged episodes per dataset and the flagged (`all_episodes`: every) episodes. `compact` (the
    terminal's table): one `flags` cell per dataset (`idle 1, jerky 2`) and each episode's flags and frame spans,
    so both fit 80 columns; the machine formats keep every column."""
    from openral_data.metrics.quality import counts_table, flag_counts, raised_text
    from openral_data.metrics.report import Table

    if compact:
        counts = Table("quality", ["dataset", "episodes", "flagged", "flags"])
        for ds, _ in computed:
            c = flag_counts(ds, th) or {}
            counts.rows.append([ds.label, c.get("episodes"), c.get("flagged"), raised_text(c)])
        detail = Table("episodes", ["dataset", "episode", "flags", "frames"])
    else:
        counts = counts_table([ds for ds, _ in computed], th)
        detail = Table("episodes", ["dataset", *DETAIL])
    for ds, q in computed:
        numbers = _numbering(ds)
        spans = _spans(q) if compact else {}
        for row in q.table.select([*DETAIL, "flagged"]).to_pylist():
            e = row["episode_index"]
            shown = numbers[e] if numbers is not None else e
            if not (all_episodes or row["flagged"]):
                continue
            if compact:
                detail.rows.append([ds.label, shown, ", ".join(row["flags"]), spans.get(e, "")])
            else:
                detail.rows.append([ds.label, shown, *(row[c] for c in DETAIL[1:])])
    return [counts, detail]


def _spans(q: Any) -> dict[int, str]:
    """Per episode: the frame spans of its first flagging findings (`12-30, 45`), `…` when there are more."""
    import pyarrow.parquet as pq

    out: dict[int, list[str]] = {}
    for f in pq.read_table(q.paths.findings).to_pylist():
        if f["flag"] and f["start_frame"] is not None:
            a, b = f["start_frame"], f["end_frame"]
            out.setdefault(f["episode_index"], []).append(f"{a}" if a == b else f"{a}-{b}")
    return {e: ", ".join(s[:SPANS_SHOWN]) + (", …" if len(s) > SPANS_SHOWN else "") for e, s in out.items()}


def _episode_findings(ds: Any, q: Any, episode: int) -> Any:
    """Episode `episode`'s findings (as the user numbers it): check (`(info)` for one that raises no flag),
    subject, frames, value and threshold."""
    import pyarrow.parquet as pq

    from openral_data.metrics.report import Table

    numbers = _numbering(ds)
    internal = numbers.index(episode) if numbers is not None and episode in numbers else episode
    if internal not in q.table.column("episode_index").to_pylist():
        raise UsageError(f"--episode: {episode}: no such episode in {ds.label} ({q.table.num_rows} episodes)")
    table = Table("findings", ["check", "subject", "frames", "value", "threshold"])
    for f in pq.read_table(q.paths.findings).to_pylist():
        if f["episode_index"] != internal:
            continue
        a, b = f["start_frame"], f["end_frame"]
        frames = "" if a is None else f"{a}" if a == b else f"{a}-{b}"
        check = f["check"] if f["flag"] else f"{f['check']} (info)"
        table.rows.append([check, f["subject"], frames, _number(f["value"]), _number(f["threshold"])])
    return table


def _number(value: float | None) -> str:
    return "" if value is None or math.isnan(value) else f"{value:.4g}"
