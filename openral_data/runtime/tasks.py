"""`--task` and `--instruction`: which task of a suite scene a run records, and the instruction it records.

Scene types with tasks declare them next to their producer (`suite_tasks`, see openral_data.producers.sim.tasks);
`SCENE_TASKS` maps the built-in scene types to those declarations (imported only when asked). A scene type
without tasks refuses `--task`; an unknown id is one line listing the valid ones.

The instruction a run records for every frame (and gives the policy) is, first to last: `--instruction`, the
scene's own language for the task (LIBERO's per task; the adapter's description for a `--task` of the other
suites), the YAML's `task.instruction`.
"""

from __future__ import annotations

from dataclasses import replace

from openral_data.errors import UsageError
from openral_data.producers.sim.tasks import SuiteTask, TaskLister, with_task
from openral_data.schemas.scene import SimScene
from openral_data.types import Observation

SHOWN = 12  # ids an "unknown task" line lists before pointing at `list tasks`


def _metaworld(scene: SimScene, source: str) -> list[SuiteTask]:
    from openral_data.producers.sim import metaworld

    return metaworld.suite_tasks(scene, source)


def _libero(scene: SimScene, source: str) -> list[SuiteTask]:
    from openral_data.producers.sim.libero import scene as libero

    return libero.suite_tasks(scene, source)


def _robosuite(scene: SimScene, source: str) -> list[SuiteTask]:
    from openral_data.producers.sim import robosuite

    return robosuite.suite_tasks(scene, source)


def _aloha(scene: SimScene, source: str) -> list[SuiteTask]:
    from openral_data.producers.sim import aloha

    return aloha.suite_tasks(scene, source)


SCENE_TASKS: dict[str, TaskLister] = {
    "metaworld": _metaworld,
    "libero": _libero,
    "robosuite": _robosuite,
    "gym_aloha": _aloha,
}


def scene_tasks(scene: SimScene, source: str) -> list[SuiteTask]:
    """The tasks of `scene`'s type; UsageError (one line) for a scene type that has none."""
    lister = SCENE_TASKS.get(scene.scene.type)
    if lister is None:
        with_tasks = ", ".join(sorted(SCENE_TASKS))
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
    ids = [t.id for t in tasks]
    shown = ", ".join(ids[:SHOWN])
    more = f", ... ({len(ids)} in all: openral-data list tasks {scene.scene.id})" if len(ids) > SHOWN else ""
    raise UsageError(f"--task: unknown task {task_id!r} of scene {scene.scene.id}; valid: {shown}{more}")


def check_instruction(instruction: str | None) -> None:
    if instruction is not None and not instruction.strip():
        raise UsageError("--instruction: must not be empty")


def instructed(obs: Observation, instruction: str | None) -> Observation:
    """`obs` carrying `instruction` as its task (`--instruction`), or unchanged when none is given."""
    return obs if instruction is None or obs.task == instruction else replace(obs, task=instruction)


def tasks_of(scene_ref: str) -> tuple[SimScene, list[SuiteTask]]:
    """`list tasks SCENE`: the scene (an id or a YAML path) and its type's tasks."""
    from openral_data.runtime.registry import resolve_scene_path
    from openral_data.schemas.scene import load_recordable_scene

    path = resolve_scene_path(scene_ref)
    scene = load_recordable_scene(path)
    return scene, scene_tasks(scene, str(path))
