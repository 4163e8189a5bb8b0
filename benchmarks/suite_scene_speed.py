"""Steps per second of the benchmark-suite scenes (gym-pusht, gym-aloha, LIBERO), with the YAML's cameras and
without any, in one process: the README's "Scenes" rows. Scene construction and reset are not timed; a
terminated episode is reset (untimed) and stepping goes on.

Usage: `.venv/bin/python benchmarks/suite_scene_speed.py [SCENE ...] [--steps 200]` (default: pusht,
aloha_transfer_cube, aloha_insertion); LIBERO from its own environment:
`.venv-libero/bin/python benchmarks/suite_scene_speed.py libero_spatial libero_object libero_goal libero_10`.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("MUJOCO_GL", "egl")

from openral_data import registry
from openral_data.schemas.scene import SimScene, load_recordable_scene

RSKILL = {"gym_pusht": "random-pusht", "gym_aloha": "random-aloha", "libero": "random-libero"}


def steps_per_second(scene: SimScene, steps: int, seed: int = 1) -> float:
    rskill = registry.resolve_rskill(RSKILL[scene.scene.type])[0]
    robot = registry.ROBOTS[scene.scene.robot or ""]
    env = registry.SCENES[scene.scene.type](scene, robot, rskill, scene.scene.id)
    policy = registry.POLICIES[rskill.policy](rskill)
    try:
        obs = env.reset(seed)
        policy.reset(seed)
        busy = 0.0
        for _ in range(steps):
            action = policy.step(obs, obs.task)
            t0 = time.perf_counter()
            result = env.step(action)
            busy += time.perf_counter() - t0
            obs = result.observation
            if result.terminated:
                seed += 1
                obs = env.reset(seed)
        return steps / busy
    finally:
        env.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenes", nargs="*", default=["pusht", "aloha_transfer_cube", "aloha_insertion"])
    parser.add_argument("--steps", type=int, default=200)
    args = parser.parse_args()
    print("| scene | cameras | steps/s with cameras | steps/s without cameras |")
    print("|---|---|---|---|")
    for scene_id in args.scenes:
        scene = load_recordable_scene(registry.resolve_scene_path(scene_id))
        bare = scene.model_copy(update={"scene": scene.scene.model_copy(update={"cameras": []})})
        with_cams = steps_per_second(scene, args.steps)
        without = steps_per_second(bare, args.steps)
        cams = ", ".join(f"{c.name} {c.width}×{c.height}" for c in scene.scene.cameras)
        print(f"| {scene_id} | {cams} | {with_cams:.1f} | {without:.1f} |", flush=True)


if __name__ == "__main__":
    main()
