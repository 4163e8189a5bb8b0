"""`openral-data pipeline run FILE.yaml`: a thin typer wrapper over `pipeline.runner`."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from openral_data import paths
from openral_data.cli.terminal import print_done, print_line

pipeline_app = typer.Typer(no_args_is_help=True, help="Run declarative, resumable campaigns (pipelines/*.yaml).")


def _figures(summary: dict[str, Any]) -> str:
    """One short line per step: episodes/frames/success of its items."""
    parts = []
    for item, s in summary.items():
        if not isinstance(s, dict):
            continue
        bits = [f"{k} {s[k]}" for k in ("episodes", "frames", "success_rate", "reproduced") if k in s]
        parts.append(f"{item}: {', '.join(bits)}" if bits else item)
    return "; ".join(parts)


@pipeline_app.command("run")
def run_cmd(
    spec: Annotated[Path, typer.Argument(help="pipeline YAML, e.g. pipelines/mock_campaign.yaml")],
    workdir: Annotated[Path | None, typer.Option(help="run folder (default: runs/<name>)")] = None,
) -> None:
    """Run the steps of SPEC in order; steps completed by an earlier run with the same config are skipped."""
    from openral_data.pipeline.runner import run_pipeline

    if workdir is not None:
        paths.check_creatable(workdir, "--workdir")
    report = run_pipeline(spec, workdir, log=lambda line: print_line(line, err=True))
    print_done(f"pipeline {report.name}: {report.workdir}")
    for step in report.steps:
        line = f"  {step['step']:<12} {step['kind']:<7} {step['status']:<8} {step['seconds']:>7.1f} s  "
        print_done(line + _figures(step["summary"]))
    print_done(f"  report: {report.workdir / 'report.json'}")
