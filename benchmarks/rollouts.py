"""The plain rollout loop the benchmarks share (expert_rates.py, metaworld_expert_rates.py, maniskill_expert_rates.py,
the baseline of bench_record_overhead.py): a policy driving a scene, seed after seed, with nothing recorded."""

from __future__ import annotations

import argparse
from collections.abc import Callable, Iterable

from openral_data.policies.base import PolicyAdapter
from openral_data.runtime import registry
from openral_data.schemas.scene import SimScene
from openral_data.types import SimRollout


def roll_out(env: SimRollout, policy: PolicyAdapter, seeds: Iterable[int], max_steps: int) -> tuple[int, int]:
    """Run `policy` in `env` from each seed until the scene terminates or `max_steps` steps; close `env` at the
    end. Returns (successful episodes, steps taken in all)."""
    wins, steps = 0, 0
    try:
        for seed in seeds:
            obs = env.reset(seed)
            policy.reset(seed)
            for _ in range(max_steps):
                steps += 1
                result = env.step(policy.step(obs, obs.task))
                obs = result.observation
                if result.terminated:
                    wins += result.success
                    break
    finally:
        env.close()
    return wins, steps


def expert_rate(scene: SimScene, robot: str, rskill_id: str, seeds: range, max_steps: int) -> tuple[int, float]:
    """An rSkill's successes on `scene` over `seeds` (each up to `max_steps`), and its mean steps per episode."""
    rskill = registry.resolve_rskill(rskill_id)[0]
    env = registry.SCENES[scene.scene.type](scene, registry.ROBOTS[robot], rskill, scene.scene.id)
    policy = registry.POLICIES[rskill.policy](rskill)
    wins, steps = roll_out(env, policy, seeds, max_steps)
    return wins, steps / len(seeds)


Rate = Callable[[str, int, int], tuple[int, float]]  # (task, first seed, seeds) -> (successes, mean steps)


def rates_main(doc: str, rate: Rate, tasks: str, first: int, seeds: int) -> None:
    """The expert-rate scripts' command line (`--seeds`, `--first`, `--tasks`) and their markdown table: per task,
    `rate(task, first, seeds)` -> (successes, mean steps per episode)."""
    parser = argparse.ArgumentParser(description=doc)
    parser.add_argument("--seeds", type=int, default=seeds)
    parser.add_argument("--first", type=int, default=first)
    parser.add_argument("--tasks", default=tasks)
    args = parser.parse_args()
    last = args.first + args.seeds - 1
    print(f"| task | success (seeds {args.first}-{last}) | steps per episode, mean |")
    print("|---|---|---|")
    for task in args.tasks.split(","):
        wins, mean = rate(task, args.first, args.seeds)
        print(f"| `{task}` | {wins}/{args.seeds} ({100 * wins / args.seeds:.0f} %) | {mean:.0f} |", flush=True)
