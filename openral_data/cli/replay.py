"""The `openral-data replay` command body: progress bar and readable summary around `replay()`."""

from __future__ import annotations

import typer
from rich.console import Console
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from openral_data.replay.command import ReplayOptions, ReplaySummary, replay
from openral_data.replay.outcome import EpisodeOutcome


def run_replay(opts: ReplayOptions, console: Console, err_console: Console) -> ReplaySummary:
    with Progress(
        TextColumn(f"[bold]replay ({opts.mode})"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("episodes"),
        TextColumn("{task.fields[agree]}"),
        TimeElapsedColumn(),
        console=err_console,
        disable=not err_console.is_terminal,
    ) as bar:
        task = bar.add_task("replay", total=None, agree="")
        agree = [0, 0]

        def progress(outcome: EpisodeOutcome | None, done: int, total: int) -> None:
            if outcome is not None and outcome.success_agrees is not None:
                agree[0] += int(outcome.success_agrees)
                agree[1] += 1
            text = f"success agrees {agree[0]}/{agree[1]}" if agree[1] else ""
            bar.update(task, total=total, completed=done, agree=text)

        try:
            summary = replay(opts, progress)
        except KeyboardInterrupt:
            bar.stop()
            kept = f"; finished episodes are kept in {opts.record}" if opts.record is not None else ""
            err_console.print(f"interrupted: no results written{kept}", markup=False, highlight=False)
            raise typer.Exit(130) from None
    rows = summary.rows()
    width = max(len(k) for k, _ in rows)
    console.print("replayed" if opts.mode == "actions" else "evaluated", markup=False, highlight=False)
    for key, value in rows:
        console.print(f"  {key:<{width}}  {value}", markup=False, highlight=False, soft_wrap=True)
    return summary
