"""Success rates of the scripted experts on every shipped robot (the expert table in benchmarks/README.md).

Runs each (robot, task) on seeds 0..N-1 (default 50) without cameras (physics does not depend on them), each
task's scene YAML with its default rSkill, and prints a Markdown table (one row per robot, one column per task).
Usage: `.venv/bin/python benchmarks/expert_rates.py [--seeds 50] [--robots a,b] [--tasks push,stack]`.
"""

from __future__ import annotations

import argparse
import time

from rollouts import roll_out

from openral_data.producers.sim.mujoco.scene import TabletopScene
from openral_data.runtime import registry
from openral_data.schemas.scene import load_recordable_scene

# task column -> scene id (scenes/sim/<id>.yaml); the expert is the scene's default_rskill
TASKS = {
    "push": "tabletop_push",
    "pick-place": "tabletop_pick_place",
    "stack": "tabletop_stack",
    "place-on": "tabletop_place_on",
    "open-drawer": "tabletop_open_drawer",
    "pick-from-clutter": "tabletop_pick_clutter",
}


def rate(robot: str, scene_id: str, seeds: int) -> tuple[int, float]:
    scene_cfg = load_recordable_scene(registry.resolve_scene_path(scene_id))
    scene_cfg = scene_cfg.model_copy(update={"scene": scene_cfg.scene.model_copy(update={"cameras": []})})
    rskill = registry.resolve_rskill(scene_cfg.scene.default_rskill or "")[0]
    scene = TabletopScene(scene_cfg, registry.ROBOTS[robot], rskill, None)
    policy = registry.POLICIES[rskill.policy](rskill)
    ok, steps = roll_out(scene, policy, range(seeds), scene_cfg.task.max_steps)
    return ok, steps / seeds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", type=int, default=50)
    tabletop = [r for r in registry.robot_ids() if (sim := registry.ROBOTS[r].sim) and sim.get("tabletop") is not False]
    parser.add_argument("--robots", default=",".join(tabletop))
    parser.add_argument("--tasks", default=",".join(TASKS), help=f"of {', '.join(TASKS)}")
    args = parser.parse_args()
    tasks = args.tasks.split(",")
    span = f"seeds 0-{args.seeds - 1}"
    print(f"| robot | gripper | {' | '.join(f'{task} ({span})' for task in tasks)} |")
    print("|---|---|" + "---|" * len(tasks))
    for robot in args.robots.split(","):
        t0 = time.perf_counter()
        cells = []
        for task in tasks:
            ok, mean_steps = rate(robot, TASKS[task], args.seeds)
            cells.append(f"{ok}/{args.seeds} ({ok / args.seeds:.0%}), {mean_steps:.0f} steps avg")
        gripper = (registry.ROBOTS[robot].assets.gripper_mjcf or "-").rsplit("/", 1)[-1].removesuffix(".xml")
        took = time.perf_counter() - t0
        print(f"| {robot} | {gripper} | {' | '.join(cells)} |  <!-- {took:.0f} s -->", flush=True)


if __name__ == "__main__":
    main()
