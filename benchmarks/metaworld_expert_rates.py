"""Success of the metaworld-expert rSkill per MetaWorld task (the MetaWorld expert table in benchmarks/README.md).

Each task runs seeds S..S+N-1 (default 1000..1019, the benchmark YAMLs' first 20 seeds) without cameras (physics
does not depend on them), up to MetaWorld's 500 steps. Usage:
`.venv/bin/python benchmarks/metaworld_expert_rates.py [--seeds 20] [--first 1000] [--tasks pick-place-v3,...]`.
"""

from __future__ import annotations

from rollouts import expert_rate, rates_main

from openral_data.runtime import registry
from openral_data.schemas.scene import load_recordable_scene

TASKS = "pick-place-v3,push-v3,door-open-v3,drawer-open-v3,button-press-topdown-v3,window-open-v3"


def rate(task: str, first: int, seeds: int) -> tuple[int, float]:
    scene = load_recordable_scene(registry.resolve_scene_path("metaworld_pick_place"))
    spec = scene.scene.model_copy(update={"cameras": [], "params": {"task": task}})
    scene = scene.model_copy(update={"scene": spec})
    return expert_rate(scene, "metaworld_sawyer", "metaworld-expert", range(first, first + seeds), 500)


if __name__ == "__main__":
    rates_main(__doc__ or "", rate, TASKS, first=1000, seeds=20)
