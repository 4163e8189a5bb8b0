"""Run a pipeline: steps in order, each skipped when its marker says it completed with the same config."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from openral_data import manifests
from openral_data.errors import ConfigError, OpenralError
from openral_data.formats.atomic import write_bytes
from openral_data.formats.staging import Staging
from openral_data.pipeline.schema import Pipeline, load_pipeline
from openral_data.pipeline.state import StepState
from openral_data.pipeline.steps import Resolve, jobs_for

Log = Callable[[str], None]


@dataclass
class PipelineReport:
    name: str
    workdir: Path
    steps: list[dict[str, Any]] = field(default_factory=list)  # marker bodies + "status": ran | skipped
    seconds: float = 0.0

    def as_json(self) -> dict[str, Any]:
        return {
            "pipeline": self.name,
            "workdir": str(self.workdir),
            "seconds": round(self.seconds, 3),
            "steps": self.steps,
        }


def default_workdir(pipeline: Pipeline) -> Path:
    return manifests.project_dir() / "runs" / pipeline.name


def run_pipeline(spec_path: Path, workdir: Path | None = None, log: Log | None = None) -> PipelineReport:
    pipeline = load_pipeline(spec_path)
    workdir = workdir or default_workdir(pipeline)
    workdir.mkdir(parents=True, exist_ok=True)
    _keep_spec(spec_path, workdir)
    report = PipelineReport(pipeline.name, workdir)
    outputs: dict[str, dict[str, str]] = {}  # step id -> item name -> path
    folder = spec_path.absolute().parent  # where `load_pipeline` anchored the file references

    def resolve(ref: str) -> list[tuple[str, Path]]:
        step_id, _, item = ref.partition("/")
        items = outputs[step_id]
        if item:
            if item not in items:
                raise ConfigError(
                    f"{spec_path}: {ref!r}: step {step_id} has no output {item!r} (has: {', '.join(items)})"
                )
            return [(item, Path(items[item]))]
        return [(k, Path(v)) for k, v in items.items()]

    t0 = time.perf_counter()
    try:
        for step in pipeline.steps:
            report.steps.append(_run_step(StepState(workdir, step, folder), resolve, outputs, log))
    except BaseException as exc:
        failed = next((st for st in pipeline.steps if st.id not in outputs), None)
        if failed is not None:
            report.steps.append({"step": failed.id, "kind": failed.kind, "status": "failed", "error": str(exc)})
        report.seconds = time.perf_counter() - t0
        write_bytes(workdir / "report.json", json.dumps(report.as_json(), indent=2).encode())
        raise
    report.seconds = time.perf_counter() - t0
    write_bytes(workdir / "report.json", json.dumps(report.as_json(), indent=2).encode())
    return report


def _run_step(
    state: StepState, resolve: Resolve, outputs: dict[str, dict[str, str]], log: Log | None
) -> dict[str, Any]:
    step = state.step
    done = state.completed()
    if done is not None:
        outputs[step.id] = done["outputs"]
        if log:
            log(f"{step.id} ({step.kind}): done earlier, skipped")
        return {**done, "status": "skipped"}
    started = time.perf_counter()
    items: dict[str, str] = {}
    summaries: dict[str, Any] = {}
    for name, run in jobs_for(step, resolve):
        previous = state.item_done(name)
        if previous is not None:
            summaries[name] = previous["summary"]
            if log:
                log(f"{step.id}/{name}: done earlier, skipped")
        else:
            if log:
                log(f"{step.id}/{name}: running")
            path = state.start_item(name)
            staged = Staging(path, f"openral-data pipeline {step.id}/{name}", create=False)
            with staged as staging:  # the item appears under its name complete, or not at all
                try:
                    summaries[name] = run(staging)
                except OpenralError as exc:
                    raise exc.amended(f"pipeline step {step.id}/{name}: {exc}") from None
                staged.publish(f"pipeline output {step.id}/{name}")
            state.finish_item(name, summaries[name])
        items[name] = str(state.item(name))
    body = state.finish(items, summaries, time.perf_counter() - started)
    outputs[step.id] = items
    if log:
        log(f"{step.id} ({step.kind}): completed in {body['seconds']:.1f} s")
    return {**body, "status": "ran"}


def _keep_spec(spec_path: Path, workdir: Path) -> None:
    """A copy of the YAML this run used, beside the outputs (provenance)."""
    write_bytes(workdir / "pipeline.yaml", spec_path.read_bytes())
