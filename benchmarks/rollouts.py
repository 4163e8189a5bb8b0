"""The plain rollout loop the benchmarks share (expert_rates.py, metaworld_expert_rates.py, the baseline of
bench_record_overhead.py): a policy driving a scene, seed after seed, with nothing recorded."""

from __future__ import annotations

from collections.abc import Iterable

from openral_data.policies.base import PolicyAdapter
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
