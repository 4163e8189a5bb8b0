"""`record --hal`: the run and its printed summary (cli/record.py builds the options; the work is in
openral_data/record/hal.py)."""

from __future__ import annotations

from typing import Any

import typer

from openral_data.cli import terminal
from openral_data.cli.jsonout import print_json
from openral_data.cli.terminal import INTERRUPTED_RECORDING, print_line, print_summary
from openral_data.record.hal import HalRecordOptions, HalRecordSummary, record_hal


def run_hal_record(opts: HalRecordOptions, json: bool = False) -> None:
    """Record through the HAL with options the CLI built (and checked: `HalRecordOptions`), then print the summary.
    The person's prompts (the keys, once the options are resolved; each episode's task, the reset countdown,
    what was decided) and the teleop's status lines (on a terminal only) go to stderr, except under -q or --json."""
    talk = not (json or terminal.quiet)
    try:
        s = record_hal(opts, (lambda line: print_line(line, err=True)) if talk else None)
    except KeyboardInterrupt:
        print_line(INTERRUPTED_RECORDING, err=True)
        raise typer.Exit(130) from None
    if json:
        print_json("record", {"hal": opts.robot, "mode": opts.mode, "fps": opts.fps, **s.to_json()})
    else:
        _print_summary(s, opts.fps)
    if s.estop is not None:
        raise typer.Exit(1)


def _print_summary(s: HalRecordSummary, fps: int) -> None:
    rows = [
        ("output", str(s.out)),
        *([("resumed at", f"episode {s.resumed_at}")] if s.resumed_at else []),
        ("episodes", f"{len(s.episodes)} kept, {s.discarded} discarded"),
        ("frames", str(s.frames)),
        ("fps", str(fps)),
        ("overruns", f"{s.overruns} ({s.missed_ticks} ticks missed)"),
        ("stale ticks", str(s.stale_ticks)),
        ("repeated samples", str(s.repeated_samples)),
        *[(f"camera {name}", _camera(cam)) for name, cam in s.capture.cameras.items()],
        ("safety interventions", str(s.interventions)),
        ("verdicts", ", ".join(r.verdict for r in s.reports) or "-"),
        *[("recovered", line) for line in s.recovered],
    ]
    if s.estop is not None:
        rows.append(("e-stop", s.estop))
    print_summary("recorded (hal)", rows)


def _camera(cam: dict[str, Any]) -> str:
    """A camera's line of the summary: how its kept episodes' frames were captured and encoded."""
    return (
        f"{cam['frames']} frames, {cam['spilled']} spilled to disk, oldest sample "
        f"{cam['worst_frame_age_s'] * 1000:.0f} ms, longest encoder wait {cam['encoder_lag_s']:.2f} s"
    )
