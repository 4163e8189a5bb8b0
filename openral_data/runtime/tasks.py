"""`--task` and `--instruction`: which task of a suite scene a run records, and the instruction it records.

Scene types with tasks declare them next to their producer (`suite_tasks`, see openral_data.producers.sim.tasks);
the scene type's one registration in `SCENES` (a `SceneType`, runtime/registry.py) names that declaration, imported
only when asked. A scene type without tasks refuses `--task`; an unknown id is one line listing the valid ones.

The instruction a run records for every frame (and gives the policy) is, first to last: `--instruction`, the
scene's own language for the task (LIBERO's per task; the adapter's description for a `--task` of the other
suites), the YAML's `task.instruction`.
"""

from __future__ import annotations

from dataclasses import replace

from openral_data.errors import UsageError
from openral_data.producers.sim.tasks import SuiteTask, with_task
from openral_data.runtime.registry import resolve_scene_path, scene_types_with_tasks, task_lister
from openral_data.schemas.scene import SimScene
from openral_data.text import choices_hint
from openral_data.types import Observation


def scene_tasks(scene: SimScene, source: str) -> list[SuiteTask]:
    """The tasks of `scene`'s type; UsageError (one line) for a scene type that has none."""
    lister = task_lister(scene.scene.type)
    if lister is None:
        with_tasks = ", ".join(scene_types_with_tasks())
        raise UsageError(
            f"{source}: scene.type: {scene.scene.type!r} scenes have no tasks to choose (--task); "
            f"scene types with tasks: {with_tasks}"
        )
    return lister(scene, source)


def choose_task(scene: SimScene, task_id: str, source: str) -> tuple[SimScene, str]:
    """`scene` running task `task_id` (an id or an alias), and the task's id."""
    tasks = scene_tasks(scene, source)
    for task in tasks:
        if task_id == task.id or task_id in task.aliases:
            return with_task(scene, task), task.id
    hint = choices_hint(task_id, [t.id for t in tasks], f"openral-data list tasks {scene.scene.id}")
    raise UsageError(f"--task: unknown task {task_id!r} of scene {scene.scene.id}; {hint}")


def with_randomize(scene: SimScene, enabled: bool, source: str) -> SimScene:
    """`scene` with its `scene.params.randomize` block turned on or off (`record --randomize on|off`)."""
    block = scene.scene.params.get("randomize")
    if not isinstance(block, dict):
        raise UsageError(
            f"--randomize: {source}: scene.params.randomize: scene {scene.scene.id} declares no randomization "
            "(docs/scenes.md: Randomization)"
        )
    params = {**scene.scene.params, "randomize": {**block, "enabled": enabled}}
    return scene.model_copy(update={"scene": scene.scene.model_copy(update={"params": params})})


def check_instruction(instruction: str | None) -> None:
    if instruction is not None and not instruction.strip():
        raise UsageError("--instruction: must not be empty")


def instructed(obs: Observation, instruction: str | None) -> Observation:
    """`obs` carrying `instruction` as its task (`--instruction`), or unchanged when none is given."""
    return obs if instruction is None or obs.task == instruction else replace(obs, task=instruction)


def tasks_of(scene_ref: str) -> tuple[SimScene, list[SuiteTask]]:
    """`list tasks SCENE`: the scene (an id or a YAML path) and its type's tasks."""
    from openral_data.schemas.scene import load_recordable_scene

    path = resolve_scene_path(scene_ref)
    scene = load_recordable_scene(path)
    return scene, scene_tasks(scene, str(path))
