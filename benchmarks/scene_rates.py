"""Success rates of scenes' default rSkills on seeds 0..N-1, any scene type (the robosuite humanoid and bimanual
rows of benchmarks/README.md, whose default rSkills are random: no expert ships for them).

Runs each scene without cameras (physics does not depend on them) for its task's max_steps and prints a Markdown
table. Usage: `.venv/bin/python benchmarks/scene_rates.py --scenes robosuite_g1_lift,robosuite_h1_lift [--seeds 10]`.
"""

from __future__ import annotations

import argparse
import time

from rollouts import roll_out

from openral_data.runtime import registry
from openral_data.schemas.scene import load_recordable_scene


def rate(scene_id: str, seeds: int) -> tuple[str, str, int, int]:
    """(robot, rSkill, successes, steps) of the scene's default rSkill on seeds 0..seeds-1."""
    cfg = load_recordable_scene(registry.resolve_scene_path(scene_id))
    cfg = cfg.model_copy(update={"scene": cfg.scene.model_copy(update={"cameras": []})})
    rskill_id = cfg.scene.default_rskill or ""
    rskill = registry.resolve_rskill(rskill_id)[0]
    robot = cfg.scene.robot or ""
    env = registry.SCENES[cfg.scene.type](cfg, registry.ROBOTS[robot], rskill, scene_id)
    ok, steps = roll_out(env, registry.POLICIES[rskill.policy](rskill), range(seeds), cfg.task.max_steps)
    return robot, rskill_id, ok, steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", required=True, help="comma-separated scene ids")
    parser.add_argument("--seeds", type=int, default=10)
    args = parser.parse_args()
    print("| scene | robot | rSkill | successes | mean steps | s/episode |")
    print("|---|---|---|---|---|---|")
    for scene_id in args.scenes.split(","):
        start = time.perf_counter()
        robot, rskill_id, ok, steps = rate(scene_id, args.seeds)
        per, mean = (time.perf_counter() - start) / args.seeds, steps / args.seeds
        print(f"| `{scene_id}` | `{robot}` | `{rskill_id}` | {ok}/{args.seeds} | {mean:.0f} | {per:.1f} |")


if __name__ == "__main__":
    main()
