"""Steps per second of every registered scene, with and without its cameras (benchmarks/README.md: scene speeds).

For each scene YAML in SCENES below (one per scene type / task family), the scene is built twice — with the
cameras its YAML declares and with none — and driven by the listed rSkill for `--steps` control steps (episodes
reset when they end; reset time and 10 warm-up steps are not counted). A step is `policy.step` + `scene.step`,
which includes rendering the cameras into the observation. Nothing is written (no encoder, no sink): this is the
producer's own speed.

Usage: `.venv/bin/python benchmarks/scene_speed.py [--scenes a,b] [--steps 200]` (default: every scene of the
default environment); LIBERO from its own environment: `.venv-libero/bin/python benchmarks/scene_speed.py
--scenes libero_spatial,libero_object,libero_goal,libero_10`. Prints one Markdown row per scene. Other simulators
add an entry to SCENES (scene id -> rSkill id, install extra).
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("MUJOCO_GL", "egl")

from openral_data.runtime import registry
from openral_data.schemas.rskill import Contract
from openral_data.schemas.scene import SimScene, load_recordable_scene

# scene id (scenes/sim/) -> (rSkill that drives it, install extra or "core")
SCENES: dict[str, tuple[str, str]] = {
    "mock_pick": ("random-mock", "core"),
    "tabletop_push": ("scripted-push", "core"),
    "tabletop_pick_place": ("scripted-pick-place", "core"),
    "robosuite_lift": ("robosuite-panda-random", "robosuite"),
    "robosuite_stack": ("robosuite-panda-random", "robosuite"),
    "robosuite_pick_place_can": ("robosuite-panda-random", "robosuite"),
    "robosuite_door": ("robosuite-panda-random", "robosuite"),
    "metaworld_pick_place": ("metaworld-expert", "metaworld"),
    "pusht": ("random-pusht", "pusht"),
    "aloha_transfer_cube": ("random-aloha", "aloha"),
    "aloha_insertion": ("random-aloha", "aloha"),
    # LIBERO lives in its own environment: `.venv-libero/bin/python benchmarks/scene_speed.py --scenes libero_...`
    "libero_spatial": ("random-libero", "libero"),
    "libero_object": ("random-libero", "libero"),
    "libero_goal": ("random-libero", "libero"),
    "libero_10": ("random-libero", "libero"),
}
DEFAULT = [scene for scene, (_, extra) in SCENES.items() if extra != "libero"]


def steps_per_second(scene: SimScene, rskill_id: str, steps: int, cameras: bool) -> float:
    if not cameras:
        scene = scene.model_copy(update={"scene": scene.scene.model_copy(update={"cameras": []})})
    rskill = registry.resolve_rskill(rskill_id)[0]
    robot = registry.ROBOTS[scene.scene.robot or ""]
    env = registry.SCENES[scene.scene.type](scene, robot, rskill, scene.scene.id)
    policy = registry.POLICIES[rskill.policy](rskill)
    elapsed, done, seed = 0.0, 0, 0
    try:
        obs = env.reset(10_000)  # warm-up, not timed: JIT compilation (robosuite uses numba), caches, GL contexts
        policy.reset(10_000)
        for _ in range(10):
            obs = env.step(policy.step(obs, obs.task)).observation
        while done < steps:
            obs = env.reset(seed)
            policy.reset(seed)
            t0 = time.perf_counter()
            for _ in range(min(scene.task.max_steps, steps - done)):
                result = env.step(policy.step(obs, obs.task))
                obs = result.observation
                done += 1
                if result.terminated:
                    break
            elapsed += time.perf_counter() - t0
            seed += 1
    finally:
        policy.close()
        env.close()
    return done / elapsed


def action_space(c: Contract) -> str:
    bounds = ""
    if c.low is not None and c.high is not None:
        bounds = f" in [{min(c.low):g}, {max(c.high):g}]"
    return f"{c.dim}-D `{c.representation}`{bounds}"


def row(scene_id: str, steps: int) -> str:
    rskill_id, extra = SCENES[scene_id]
    scene = load_recordable_scene(registry.resolve_scene_path(scene_id))
    rskill = registry.resolve_rskill(rskill_id)[0]
    cams = ", ".join(f"`{c.name}` {c.width}×{c.height}" for c in scene.scene.cameras) or "—"
    without = steps_per_second(scene, rskill_id, steps, cameras=False)
    with_cams = steps_per_second(scene, rskill_id, steps, cameras=True) if scene.scene.cameras else without
    kind = scene.scene.params.get("env") or scene.scene.params.get("task") or scene.scene.type
    actions = action_space(rskill.action_contract)
    return (
        f"| `{scene_id}` | {scene.scene.type} ({kind}) | `{scene.scene.robot}` | {cams} | {actions}"
        f" | {scene.scene.fps} | {without:.0f} | {with_cams:.1f} | {extra} |"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scenes", default=",".join(DEFAULT))
    parser.add_argument("--steps", type=int, default=200)
    args = parser.parse_args()
    print("| scene | type | robot | cameras (YAML) | action space (rSkill contract) | fps | steps/s, no cameras | "
          "steps/s, with cameras | extra |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|")
    for scene_id in args.scenes.split(","):
        print(row(scene_id, args.steps), flush=True)


if __name__ == "__main__":
    main()
