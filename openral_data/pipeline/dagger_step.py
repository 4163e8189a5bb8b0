"""The `dagger` step: the DAgger round. Each checkpoint a `train` step made drives the scene (the fixed-rate loop
of `record --scene S --teleop ...`, record/hal.py) and the scene's scripted expert is the person at the controls:
`--teleop expert` (producers/hal/teleop/expert.py), whose takeover rule presses the takeover button the loop reads
at the start of each tick, exactly as a gamepad's, so the frames it drove are marked `openral.intervention` by
the same code as a person's, their `action` is the expert's and `openral.policy_action` holds what the policy
proposed. The output is the round's dataset `<train step>--<item>` (its episodes' operator
`policy:<item>+teleop:expert`); `stats` gives its success rate and its intervention rate (`intervention_rounds`),
`merge` with `common: true` adds it to the demos for the next training.

A killed round is redone: the runner stages the item and publishes it complete or not at all, so no episode is
recorded twice."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from openral_data.pipeline.evaluate_step import CHECKPOINT
from openral_data.pipeline.schema import DaggerStep

ItemJob = tuple[str, Callable[[Path], dict[str, Any]]]


def dagger_jobs(spec: DaggerStep, resolve: Callable[[str], list[tuple[str, Path]]]) -> Iterator[ItemJob]:
    trainer = spec.policy.split("/", 1)[0]
    for name, trained in resolve(spec.policy):

        def run(out: Path, trained: Path = trained) -> dict[str, Any]:
            return _round(spec, trained / CHECKPOINT, out)

        yield f"dagger--{trainer}--{name}", run  # the round's name in `stats`' dataset column (not the evaluation's)


def _round(spec: DaggerStep, checkpoint: Path, out: Path) -> dict[str, Any]:
    from openral_data.producers.hal.teleop.declare import TakeoverRule
    from openral_data.producers.hal.teleop.expert import WHAT
    from openral_data.record.hal import HalRecordOptions, record_hal, teleop_scene

    robot, _, fps, scene_steps = teleop_scene(spec.scene, None, None)
    opts = HalRecordOptions(
        robot=robot,
        rskill=None,
        policy=str(checkpoint),
        device=spec.device,
        scene=spec.scene,
        fps=fps,
        teleop=WHAT,
        takeover=True,
        expert=spec.expert,
        takeover_rule=TakeoverRule(spec.threshold, spec.patience, spec.hold),
        n_episodes=spec.seeds.count,
        seed=spec.seeds.start,
        max_steps=spec.max_steps or scene_steps,
        out=out,
        codec=spec.codec,
    )
    summary = record_hal(opts)
    frames = [r.frames for r in summary.reports]
    return {
        "checkpoint": str(checkpoint),
        "episodes": len(summary.episodes),
        "successes": sum(e.success is True for e in summary.episodes),
        "success_rate": round(sum(e.success is True for e in summary.episodes) / max(1, len(summary.episodes)), 4),
        "frames": sum(frames),
        "seeds": [e.seed for e in summary.episodes],
    }
