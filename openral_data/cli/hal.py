"""`record --hal`: option parsing and the printed summary (the work is in openral_data/record/hal.py)."""

from __future__ import annotations

from pathlib import Path
from typing import cast

import typer

from openral_data.cli.jsonout import print_json
from openral_data.cli.terminal import INTERRUPTED_RECORDING, print_line, print_rows
from openral_data.errors import UsageError
from openral_data.formats.lerobot_v3.video import Codec
from openral_data.producers.hal.operator import HELP
from openral_data.record.hal import HalRecordOptions, HalRecordSummary, Mode, record_hal
from openral_data.schemas.hal import SafetyMode


def run_hal_record(
    robot: str,
    mode: str,
    rskill: str,
    fps: int,
    scene: str | None,
    n_episodes: int | None,
    max_steps: int | None,
    seed: int | None,
    out: Path | None,
    codec: str,
    formats: str,
    image_format: str,
    mcap_compression: str,
    operator: str,
    safety: str | None,
    staleness: float | None,
    port: str | None,
    json: bool = False,
) -> None:
    from openral_data.formats.mcap import parse_compression, parse_image_format
    from openral_data.runtime.sinks import parse_formats

    if mode not in ("sim", "real"):
        raise UsageError(f"--mode: {mode!r}; valid: sim, real")
    if safety is not None and safety not in ("clamp", "refuse"):
        raise UsageError(f"--safety: {safety!r}; valid: clamp, refuse")
    opts = HalRecordOptions(
        robot=robot,
        rskill=rskill,
        mode=cast(Mode, mode),
        fps=fps,
        scene=scene,
        n_episodes=n_episodes if n_episodes is not None else 1,
        max_steps=max_steps if max_steps is not None else 200,
        seed=seed if seed is not None else 0,
        out=out,
        codec=cast(Codec, codec),
        formats=parse_formats(formats),
        image_format=parse_image_format(image_format),
        mcap_compression=parse_compression(mcap_compression),
        operator=operator,
        safety=cast(SafetyMode | None, safety),
        staleness=staleness,
        port=port,
    )
    if operator == "keyboard":
        print_line(HELP, err=True)
    try:
        s = record_hal(opts, lambda line: print_line(line, err=True))
    except KeyboardInterrupt:
        print_line(INTERRUPTED_RECORDING, err=True)
        raise typer.Exit(130) from None
    if json:
        print_json("record", {"hal": robot, "mode": mode, "fps": fps, **s.to_json()})
    else:
        _print_summary(s, fps)
    if s.estop is not None:
        raise typer.Exit(1)


def _print_summary(s: HalRecordSummary, fps: int) -> None:
    rows = [
        ("output", str(s.out)),
        ("episodes", f"{len(s.episodes)} kept, {s.discarded} discarded"),
        ("frames", str(s.frames)),
        ("fps", str(fps)),
        ("overruns", f"{s.overruns} ({s.missed_ticks} ticks missed)"),
        ("stale ticks", str(s.stale_ticks)),
        ("repeated samples", str(s.repeated_samples)),
        ("safety interventions", str(s.interventions)),
        ("verdicts", ", ".join(r.verdict for r in s.reports) or "-"),
    ]
    if s.estop is not None:
        rows.append(("e-stop", s.estop))
    print_rows("recorded (hal)", rows)
