"""The `evaluate` step: `record --policy CHECKPOINT` of each checkpoint a `train` step made, on seeds the
training never saw. The rollouts are a dataset `<train step>--<item>` (its episodes' `operator` is
`policy:<item>`), so `stats` gives the success rate with its Wilson interval, one row per round, and `merge`
can take them."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from openral_data.pipeline.schema import EvaluateStep

ItemJob = tuple[str, Callable[[Path], dict[str, Any]]]
CHECKPOINT = "pretrained_model"  # inside a train step's item (pipeline/train_step.py)


def evaluate_jobs(spec: EvaluateStep, resolve: Callable[[str], list[tuple[str, Path]]]) -> Iterator[ItemJob]:
    trainer = spec.policy.split("/", 1)[0]
    for name, trained in resolve(spec.policy):

        def run(out: Path, trained: Path = trained) -> dict[str, Any]:
            from openral_data.formats.lerobot_v3.encoder import VideoSettings
            from openral_data.record.options import RecordOptions
            from openral_data.record.sim import record

            opts = RecordOptions(
                scene=spec.scene,
                policy=str(trained / CHECKPOINT),
                robot=spec.robot,
                n_episodes=spec.seeds.count,
                seed=spec.seeds.start,
                max_steps=spec.max_steps,
                out=out,
                video=VideoSettings.given(spec.codec),
                device=spec.device,
            )
            summary = record(opts)
            successes = sum(e.success is True for e in summary.episodes)
            return {
                "checkpoint": str(trained / CHECKPOINT),
                "episodes": len(summary.episodes),
                "successes": successes,
                "success_rate": round(summary.success_rate, 4),
                "seeds": [e.seed for e in summary.episodes],
            }

        yield f"{trainer}--{name}", run  # the round's name in `stats`' dataset column
