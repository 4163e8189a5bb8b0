"""`openral-data generate`: source demonstrations -> a plan of object-centric segments -> `record` with the
`mimicgen` policy, keeping only the episodes that succeed.

The source dataset is one of ours recorded in a MuJoCo tabletop scene with `delta_eef_gripper` actions (scripted
or teleoperated). Its successful episodes are replayed in their own scene (no cameras) and cut into segments
(`segments.py`); the plan and an rSkill naming it (the source's contracts, policy `mimicgen`) go to a hidden
folder beside OUT, removed at the end. Then `record` (or `record --workers`) runs `--n` attempts on `--scene`
(seeds `--seed`...) with `keep="success"`: OUT is an ordinary dataset of ours whose episodes each say, in
`openral.episode_info`, which source episode and segments they came from.
"""

from __future__ import annotations

import dataclasses
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

import yaml

from openral_data.errors import GenerateError, UsageError
from openral_data.formats.lerobot_v3.encoder import Codec
from openral_data.generate.annotations import Annotations, read_annotations
from openral_data.generate.segments import cuts, segments
from openral_data.generate.trace import trace
from openral_data.policies.mimicgen.plan import Demo, Plan, write_plan
from openral_data.record.options import ProgressFn, RecordOptions, RecordSummary
from openral_data.replay.rebuild import SceneView, rebuild
from openral_data.replay.recorded import RecordedDataset
from openral_data.runtime.parallel.choice import is_parallel


@dataclass(frozen=True)
class GenerateOptions:
    source: Path
    scene: str
    n: int  # episodes to keep
    out: Path
    seed: int = 1000
    max_steps: int | None = None
    interpolation: int = 5  # steps between two segments
    settle: int = 8  # frames a grasp segment runs on after the gripper closes
    annotations: Path | None = None
    workers: int = 1
    executor: str = "local"
    address: str | None = None
    codec: Codec = "av1"
    max_attempts: int | None = None  # the attempts' cap (default: ATTEMPTS_PER_EPISODE * n)


ATTEMPTS_PER_EPISODE = 3  # the default cap on attempts per episode asked for


@dataclass(frozen=True)
class GenerateSummary:
    out: Path
    source_episodes: int  # successful source episodes the plan holds
    asked: int  # --n
    attempts: int  # made (at most the cap; fewer once `asked` were kept)
    kept: int
    frames: int
    seconds: float
    record: RecordSummary

    @property
    def keep_rate(self) -> float:
        return self.kept / self.attempts if self.attempts else 0.0

    @property
    def per_minute(self) -> float:
        return 60.0 * self.kept / self.seconds if self.seconds > 0 else 0.0

    def to_json(self) -> dict[str, object]:
        return {
            "out": str(self.out),
            "source_episodes": self.source_episodes,
            "asked": self.asked,
            "attempts": self.attempts,
            "kept": self.kept,
            "keep_rate": round(self.keep_rate, 4),
            "frames": self.frames,
            "seconds": round(self.seconds, 3),
            "episodes_per_minute": round(self.per_minute, 2),
        }


def build_plan(opts: GenerateOptions) -> tuple[Plan, dict[str, object]]:
    """The plan from the source's successful episodes, and the source's rSkill as a mapping."""
    dataset = RecordedDataset(opts.source)
    manifest = dataset.rskill()
    if manifest.action_contract.representation != "delta_eef_gripper":
        raise GenerateError(
            f"{opts.source}: the source's actions are {manifest.action_contract.representation}; generation "
            "re-targets delta_eef_gripper actions (end-effector deltas)",
            code="generate.actions",
        )
    notes: Annotations | None = read_annotations(opts.annotations) if opts.annotations is not None else None
    built = rebuild(dataset, view=SceneView(cameras=()))
    demos: list[Demo] = []
    try:
        for e in range(len(dataset)):
            episode = dataset.episode(e)
            if episode.success is False:
                continue
            tr = trace(built.env, episode, str(opts.source))
            if not tr.success:
                continue
            given = notes.cuts(e, tr.length) if notes is not None else None
            plan_cuts = given if given is not None else cuts(tr, opts.settle)
            demos.append(Demo(episode=e, segments=segments(tr, plan_cuts)))
    finally:
        built.env.close()
    if not demos:
        raise GenerateError(
            f"{opts.source}: no source episode succeeds again when replayed: nothing to generate from",
            code="generate.source",
        )
    plan = Plan(source=str(opts.source.resolve()), interpolation=opts.interpolation, demos=demos)
    rskill = manifest.model_dump(mode="json", exclude_none=True)
    return plan, rskill


def generate(opts: GenerateOptions, progress: ProgressFn | None = None) -> GenerateSummary:
    """`progress`: told of each kept episode as `record` tells its bar (a parallel run reports none)."""
    if opts.n < 1:
        raise UsageError(f"--n: must be >= 1, got {opts.n}")
    cap = opts.max_attempts if opts.max_attempts is not None else ATTEMPTS_PER_EPISODE * opts.n
    if cap < 1:
        raise UsageError(f"--max-attempts: must be >= 1, got {cap}")
    if opts.settle < 0:
        raise UsageError(f"--settle: must be >= 0, got {opts.settle}")
    t0 = time.perf_counter()
    plan, rskill = build_plan(opts)
    work = opts.out.parent / f".{opts.out.name}.generate"
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    try:
        write_plan(plan, work / "plan.json")
        rskill.update(
            id=f"mimicgen-{rskill['id']}",
            description=f"MimicGen-style generation from {plan.source}",
            policy="mimicgen",
            policy_extras={"plan": str((work / "plan.json").resolve())},
        )
        (work / "rskill.yaml").write_text(yaml.safe_dump(rskill, sort_keys=False))
        record_opts = RecordOptions(
            scene=opts.scene,
            rskill=str(work / "rskill.yaml"),
            n_episodes=cap,
            keep_target=opts.n,
            seed=opts.seed,
            max_steps=opts.max_steps,
            out=opts.out,
            codec=opts.codec,
            keep="success",
        )
        summary = _record(record_opts, opts, progress)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    kept = len(summary.episodes)
    if kept == 0:
        raise GenerateError(
            f"{opts.out}: none of the {summary.discarded} generated episodes succeeded; nothing was written "
            "(try more attempts, a larger --interpolation, or other source demonstrations)",
            code="generate.nothing_kept",
        )
    return GenerateSummary(
        out=opts.out,
        source_episodes=len(plan.demos),
        asked=opts.n,
        attempts=kept + summary.discarded,
        kept=kept,
        frames=summary.frames,
        seconds=time.perf_counter() - t0,
        record=summary,
    )


def _record(record_opts: RecordOptions, opts: GenerateOptions, progress: ProgressFn | None) -> RecordSummary:
    if not is_parallel(opts.workers, opts.executor):
        from openral_data.record.sim import record

        return record(record_opts, progress)
    from openral_data.record.parallel.run import record_parallel

    return record_parallel(dataclasses.replace(record_opts), opts.workers, executor=opts.executor, address=opts.address)
