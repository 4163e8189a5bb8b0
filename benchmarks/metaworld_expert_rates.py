"""Success of the metaworld-expert rSkill per MetaWorld task (the MetaWorld expert table in benchmarks/README.md).

Each task runs seeds S..S+N-1 (default 1000..1019, the benchmark YAMLs' first 20 seeds) without cameras (physics
does not depend on them), up to MetaWorld's 500 steps. Usage:
`.venv/bin/python benchmarks/metaworld_expert_rates.py [--seeds 20] [--first 1000] [--tasks pick-place-v3,...]`.
"""

from __future__ import annotations

import argparse

from rollouts import roll_out

from openral_data.runtime import registry
from openral_data.schemas.scene import load_recordable_scene

TASKS = "pick-place-v3,push-v3,door-open-v3,drawer-open-v3,button-press-topdown-v3,window-open-v3"


def rate(task: str, first: int, seeds: int) -> tuple[int, float]:
    scene = load_recordable_scene(registry.resolve_scene_path("metaworld_pick_place"))
    spec = scene.scene.model_copy(update={"cameras": [], "params": {"task": task}})
    scene = scene.model_copy(update={"scene": spec})
    rskill = registry.resolve_rskill("metaworld-expert")[0]
    env = registry.SCENES["metaworld"](scene, registry.ROBOTS["metaworld_sawyer"], rskill, task)
    policy = registry.POLICIES[rskill.policy](rskill)
    wins, steps = roll_out(env, policy, range(first, first + seeds), 500)
    return wins, steps / seeds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--first", type=int, default=1000)
    parser.add_argument("--tasks", default=TASKS)
    args = parser.parse_args()
    last = args.first + args.seeds - 1
    print(f"| task | success (seeds {args.first}-{last}) | steps per episode, mean |")
    print("|---|---|---|")
    for task in args.tasks.split(","):
        wins, mean = rate(task, args.first, args.seeds)
        print(f"| `{task}` | {wins}/{args.seeds} ({100 * wins / args.seeds:.0f} %) | {mean:.0f} |", flush=True)


if __name__ == "__main__":
    main()
