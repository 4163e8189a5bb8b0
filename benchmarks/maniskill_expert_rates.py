"""Success of the maniskill-expert rSkill (ManiSkill3's motion-planning solutions) per ManiSkill task (the ManiSkill3
expert table in benchmarks/README.md).

Each task runs seeds S..S+N-1 (default 0..9) without cameras (physics does not depend on them), up to 200 steps;
success is ManiSkill's own `info["success"]` in the scene. Runs in ManiSkill's environment:
`.venv-maniskill/bin/python benchmarks/maniskill_expert_rates.py [--seeds 10] [--first 0] [--tasks PickCube-v1,...]`.
"""

from __future__ import annotations

import argparse
import time

from rollouts import roll_out

from openral_data.producers.sim.maniskill.tasks import TASKS, suite_tasks
from openral_data.producers.sim.tasks import with_task
from openral_data.runtime import registry
from openral_data.schemas.scene import load_recordable_scene

EXPERT_TASKS = ",".join(t.env_id for t in TASKS if t.expert is not None)


def rate(task: str, first: int, seeds: int) -> tuple[int, float]:
    scene = load_recordable_scene(registry.resolve_scene_path("maniskill_pick_cube"))
    scene = scene.model_copy(update={"scene": scene.scene.model_copy(update={"cameras": []})})
    (chosen,) = [t for t in suite_tasks(scene, task) if t.id == task]
    scene = with_task(scene, chosen)
    rskill = registry.resolve_rskill("maniskill-expert")[0]
    env = registry.SCENES["maniskill"](scene, registry.ROBOTS["maniskill_panda"], rskill, task)
    policy = registry.POLICIES[rskill.policy](rskill)
    wins, steps = roll_out(env, policy, range(first, first + seeds), 200)
    return wins, steps / seeds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--tasks", default=EXPERT_TASKS)
    args = parser.parse_args()
    last = args.first + args.seeds - 1
    print(f"| task | success (seeds {args.first}-{last}) | steps per episode, mean | seconds |")
    print("|---|---|---|---|")
    for task in args.tasks.split(","):
        t0 = time.monotonic()
        wins, mean = rate(task, args.first, args.seeds)
        seconds = time.monotonic() - t0
        print(
            f"| `{task}` | {wins}/{args.seeds} ({100 * wins / args.seeds:.0f} %) | {mean:.0f} | {seconds:.0f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
