"""Thin front end of `record --workers/--executor` (the summary lines `record` prints)."""

from __future__ import annotations

from rich.console import Console

from openral_data.record import RecordOptions


def run_parallel_cli(
    opts: RecordOptions, workers: int, executor: str, address: str | None, threads: int | None, console: Console
) -> None:
    from openral_data.parallel.run import record_parallel

    summary = record_parallel(opts, workers, executor, address, threads)
    rows = [
        ("output", str(summary.out)),
        ("episodes", str(len(summary.episodes))),
        ("success rate", f"{summary.success_rate:.1%}"),
        ("frames", str(summary.frames)),
        ("frames/s", f"{summary.fps:.1f}"),
        ("formats", ",".join(opts.formats)),
        ("workers", f"{summary.workers} ({executor}), finished in order {list(summary.finish_order)}"),
        ("codec", opts.codec),
    ]
    width = max(len(k) for k, _ in rows)
    console.print("recorded", markup=False, highlight=False)
    for key, value in rows:
        console.print(f"  {key:<{width}}  {value}", markup=False, highlight=False, soft_wrap=True)
