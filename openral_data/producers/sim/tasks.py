"""The tasks of a suite scene: what `record --task ID` may choose and `list tasks SCENE` prints.

A suite scene type (MetaWorld, LIBERO, robosuite, gym-aloha) declares its tasks next to its producer as
`suite_tasks(scene, source) -> list[SuiteTask]`: each task's id, the `scene.params` that select it and its language
instruction (the suite's own where it has one). `with_task` gives the scene that runs one of them, so the scene
config a recording stores (and a replay rebuilds) is the chosen task's.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from openral_data.schemas.scene import SimScene


@dataclass(frozen=True)
class SuiteTask:
    id: str
    instruction: str  # the task's language instruction (the suite's own, or the adapter's description)
    params: dict[str, Any] = field(default_factory=dict)  # the `scene.params` entries that select it
    aliases: tuple[str, ...] = ()  # other ids that name it (LIBERO: the bare index within the scene's suite)


TaskLister = Callable[[SimScene, str], list[SuiteTask]]  # (scene, its source) -> the scene type's tasks


def with_task(scene: SimScene, task: SuiteTask) -> SimScene:
    """`scene` running `task`: its params updated and the task's instruction as the scene's."""
    spec = scene.scene.model_copy(update={"params": {**scene.scene.params, **task.params}})
    return scene.model_copy(
        update={"scene": spec, "task": scene.task.model_copy(update={"instruction": task.instruction})}
    )
