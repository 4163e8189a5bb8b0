"""Success of the maniskill-expert rSkill (ManiSkill3's motion-planning solutions) per ManiSkill task (the ManiSkill3
expert table in benchmarks/README.md).

Each task runs seeds S..S+N-1 (default 0..9) without cameras (physics does not depend on them), up to 200 steps;
success is ManiSkill's own `info["success"]` in the scene. Runs in ManiSkill's environment:
`.venv-maniskill/bin/python benchmarks/maniskill_expert_rates.py [--seeds 10] [--first 0] [--tasks PickCube-v1,...]`.
"""

from __future__ import annotations

from rollouts import expert_rate, rates_main

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
    return expert_rate(scene, "maniskill_panda", "maniskill-expert", range(first, first + seeds), 200)


if __name__ == "__main__":
    rates_main(__doc__ or "", rate, EXPERT_TASKS, first=0, seeds=10)
