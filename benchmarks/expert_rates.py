"""Success rates of the scripted experts on every shipped robot (the expert table in benchmarks/README.md).

Runs each (robot, task) on seeds 0..N-1 (default 50) without cameras (physics does not depend on them) and
prints a Markdown table. Usage: `.venv/bin/python benchmarks/expert_rates.py [--seeds 50] [--robots a,b]`.
"""

from __future__ import annotations

import argparse
import time

from rollouts import roll_out

from openral_data.producers.sim.mujoco.scene import TabletopScene
from openral_data.record import registry
from openral_data.schemas.scene import load_recordable_scene

TASKS = {"push": "scripted-push", "pick_place": "scripted-pick-place"}


def rate(robot: str, task: str, seeds: int) -> tuple[int, float]:
    scene_cfg = load_recordable_scene(registry.resolve_scene_path(f"tabletop_{task}"))
    scene_cfg = scene_cfg.model_copy(update={"scene": scene_cfg.scene.model_copy(update={"cameras": []})})
    rskill = registry.resolve_rskill(TASKS[task])[0]
    scene = TabletopScene(scene_cfg, registry.ROBOTS[robot], rskill, task)  # type: ignore[arg-type]
    policy = registry.POLICIES[rskill.policy](rskill)
    ok, steps = roll_out(scene, policy, range(seeds), scene_cfg.task.max_steps)
    return ok, steps / seeds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", type=int, default=50)
    tabletop = [r for r in registry.robot_ids() if (sim := registry.ROBOTS[r].sim) and sim.get("tabletop") is not False]
    parser.add_argument("--robots", default=",".join(tabletop))
    args = parser.parse_args()
    print(f"| robot | gripper | push (seeds 0-{args.seeds - 1}) | pick-place (seeds 0-{args.seeds - 1}) |")
    print("|---|---|---|---|")
    for robot in args.robots.split(","):
        t0 = time.perf_counter()
        cells = []
        for task in TASKS:
            ok, mean_steps = rate(robot, task, args.seeds)
            cells.append(f"{ok}/{args.seeds} ({ok / args.seeds:.0%}), {mean_steps:.0f} steps avg")
        gripper = (registry.ROBOTS[robot].assets.gripper_mjcf or "-").rsplit("/", 1)[-1].removesuffix(".xml")
        took = time.perf_counter() - t0
        print(f"| {robot} | {gripper} | {cells[0]} | {cells[1]} |  <!-- {took:.0f} s -->", flush=True)


if __name__ == "__main__":
    main()
