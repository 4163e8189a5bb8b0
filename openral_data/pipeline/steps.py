"""What each step kind does with its resolved inputs; every function yields (item name, item summary)."""

from __future__ import annotations

import shutil
from collections.abc import Callable, Iterator
from pathlib import Path
from tempfile import TemporaryDirectory
from typing import Any

from openral_data.errors import ConfigError
from openral_data.pipeline.schema import (
    ConvertStep,
    ExportStep,
    FilterStep,
    MergeStep,
    RecordStep,
    StatsStep,
    Step,
)
from openral_data.runtime.parallel.choice import is_parallel

# (item name, run(item path) -> summary); the runner skips items already marked done
ItemJob = tuple[str, Callable[[Path], dict[str, Any]]]
Resolve = Callable[[str], list[tuple[str, Path]]]  # reference -> [(item name, path)]


def jobs_for(step: Step, resolve: Resolve) -> Iterator[ItemJob]:
    if step.record is not None:
        yield from _record_jobs(step.record)
    elif step.merge is not None:
        yield _merge_job(step.merge, resolve)
    elif step.replay is not None:
        from openral_data.pipeline.replay_step import replay_jobs

        yield from replay_jobs(step.replay, resolve)
    elif step.stats is not None:
        yield _stats_job(step.stats, resolve)
    elif step.export is not None:
        yield from _export_jobs(step.export, resolve)
    elif step.convert is not None:
        yield _convert_job(step.convert)
    elif step.filter is not None:
        yield from _filter_jobs(step.filter, resolve)
    elif step.evaluate is not None:
        from openral_data.pipeline.evaluate_step import evaluate_jobs

        yield from evaluate_jobs(step.evaluate, resolve)
    elif step.train is not None:
        from openral_data.pipeline.train_step import train_jobs

        yield from train_jobs(step.train, resolve)
    elif step.dagger is not None:
        from openral_data.pipeline.dagger_step import dagger_jobs

        yield from dagger_jobs(step.dagger, resolve)


def _record_jobs(spec: RecordStep) -> Iterator[ItemJob]:
    for name, scene, rskill, robot, task in spec.items():
        yield name, _record_one(spec, scene, rskill, robot, task)


def _record_one(
    spec: RecordStep, scene: str, rskill: str, robot: str | None, task: str | None
) -> Callable[[Path], dict[str, Any]]:
    def run(out: Path) -> dict[str, Any]:
        from openral_data.record.options import RecordOptions, RecordSummary
        from openral_data.record.sim import record

        opts = RecordOptions(
            scene=scene,
            rskill=rskill,
            robot=robot,
            n_episodes=spec.seeds.count,
            seed=spec.seeds.start,
            max_steps=spec.max_steps,
            out=out,
            video=spec.video_settings(),
            formats=tuple(spec.formats),
            image_format=spec.image_format,
            mcap_compression=spec.mcap_compression,
            task=task,
            instruction=spec.instruction,
            device=spec.device,
        )
        summary: RecordSummary
        if is_parallel(spec.workers, spec.executor):
            from openral_data.record.parallel.run import record_parallel

            summary = record_parallel(opts, spec.workers, spec.executor)
        else:
            summary = record(opts)
        return {
            "episodes": len(summary.episodes),
            "frames": summary.frames,
            "success_rate": round(summary.success_rate, 4),
            "seeds": [e.seed for e in summary.episodes],
        }

    return run


def _merge_job(spec: MergeStep, resolve: Resolve) -> ItemJob:
    sources = [path for ref in spec.inputs for _, path in resolve(ref)]

    def run(out: Path) -> dict[str, Any]:
        from openral_data.edit.ops import merge

        if not spec.common:
            result = merge(sources, out, spec.order)
            return {"episodes": result.episodes, "frames": result.frames, "sources": [str(p) for p in sources]}
        with TemporaryDirectory(prefix="openral-merge-") as tmp:  # the trimmed copies, gone with the merge
            inputs, dropped = _common_features(sources, Path(tmp))
            result = merge(inputs, out, spec.order)
        summary = {"episodes": result.episodes, "frames": result.frames, "sources": [str(p) for p in sources]}
        return {**summary, "dropped": dropped}

    return "dataset", run


def _common_features(sources: list[Path], tmp: Path) -> tuple[list[Path], dict[str, list[str]]]:
    """`sources` with only the features all of them have: an input with more (a DAgger round's
    `openral.intervention`, `openral.policy_action` and the fixed-rate loop's timing columns) is written without
    them into `tmp` first (`features remove`); the dropped features per input."""
    from openral_data.edit.features import remove
    from openral_data.formats.lerobot_v3.reader import read_info

    features = [set(read_info(src)["features"]) for src in sources]
    shared = set.intersection(*features)
    inputs, dropped = [], {}
    for i, (src, have) in enumerate(zip(sources, features, strict=True)):
        extra = sorted(have - shared)
        if extra:
            remove(src, extra, tmp / str(i))
            dropped[str(src)] = extra
        inputs.append(tmp / str(i) if extra else src)
    return inputs, dropped


def _filter_jobs(spec: FilterStep, resolve: Resolve) -> Iterator[ItemJob]:
    for name, src in resolve(spec.dataset):

        def run(out: Path, src: Path = src) -> dict[str, Any]:
            from openral_data.edit.features import remove
            from openral_data.edit.select import filter_episodes

            kept = out.with_name(f".{out.name}.kept") if spec.drop else out  # then without `drop`, into `out`
            shutil.rmtree(kept, ignore_errors=True)  # what a killed run left
            result = filter_episodes(src, spec.predicate(), kept)
            if spec.drop:
                remove(kept, spec.drop, out)
                shutil.rmtree(kept)
            return {
                "source": str(src), "where": spec.predicate(), "episodes": result.episodes, "frames": result.frames,
                "dropped": spec.drop,
            }  # fmt: skip

        yield name, run


def _stats_job(spec: StatsStep, resolve: Resolve) -> ItemJob:
    paths = [str(path) for ref in spec.inputs for _, path in resolve(ref)]

    def run(out: Path) -> dict[str, Any]:
        import json

        from openral_data.metrics.command import StatsOptions, run_stats

        text = run_stats(StatsOptions(paths, spec.by, None, "json"))
        out.mkdir(parents=True)
        (out / "stats.json").write_text(text)
        (out / "stats.md").write_text(run_stats(StatsOptions(paths, spec.by, None, "markdown")))
        tables = json.loads(text)
        groups = tables.get("groups", []) if isinstance(tables, dict) else []
        rounds = tables.get("intervention_rounds", []) if isinstance(tables, dict) else []  # the DAgger rounds'
        return {"inputs": paths, "groups": groups, "intervention_rounds": rounds}

    return "report", run


def _export_jobs(spec: ExportStep, resolve: Resolve) -> Iterator[ItemJob]:
    for name, src in resolve(spec.dataset):

        def run(out: Path, src: Path = src) -> dict[str, Any]:
            from openral_data.convert.to_mcap import export_mcap
            from openral_data.formats.mcap import McapConfig

            if spec.to != "mcap":
                raise ConfigError(f"export.to: {spec.to!r} is not supported")
            summary = export_mcap(
                src,
                out,
                episodes=spec.episodes,
                config=McapConfig(image_format=spec.image_format, compression=spec.mcap_compression),
            )
            return {"source": str(src), "episodes": len(summary.episodes), "frames": summary.frames}

        yield name, run


def _convert_job(spec: ConvertStep) -> ItemJob:
    def run(out: Path) -> dict[str, Any]:
        from openral_data.convert.entry import convert
        from openral_data.convert.kinds.base import Parallel
        from openral_data.formats.lerobot_v3.encoder import VideoSettings

        video = VideoSettings.given(spec.codec) if spec.codec is not None else None
        parallel = Parallel(spec.workers) if is_parallel(spec.workers, "local") else None
        mapping = Path(spec.mapping) if spec.mapping is not None else None
        summary = convert(Path(spec.source), out, mapping, video=video, parallel=parallel, fps=spec.fps)
        return {"source": spec.source, "episodes": len(summary.episodes), "frames": summary.frames}

    return "dataset", run
