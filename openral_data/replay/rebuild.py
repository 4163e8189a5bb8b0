"""Rebuild the recorded scene: the scene config, robot and rSkill stored in the dataset, never today's YAML.

Any registered scene type works (`registry.SCENES`); the only requirement is `spec.can_restore_state`. A
`record --hal` recording of a robot (the real one or its twin, no scene) is rebuilt as that robot's MuJoCo twin
(`mujoco_twin`, producers/sim/mujoco/twin.py) at the dataset's fps, starting where the robot started.
"""

from __future__ import annotations

from dataclasses import dataclass

from openral_data.errors import ReplayError
from openral_data.replay.recorded import RecordedDataset
from openral_data.runtime import registry
from openral_data.schemas.robot import RobotManifest
from openral_data.schemas.rskill import RSkillManifest
from openral_data.schemas.scene import RenderConfig, SceneCamera, SceneSpec, SimScene, TaskSpec
from openral_data.types import SimRollout


@dataclass(frozen=True)
class SceneView:
    """How the rebuilt scene renders: None keeps the recorded cameras; [] renders nothing (fastest)."""

    cameras: tuple[SceneCamera, ...] | None = None
    render: RenderConfig | None = None


@dataclass
class Rebuilt:
    env: SimRollout
    scene: SimScene
    robot: RobotManifest
    rskill: RSkillManifest
    source: str
    rskill_source: str


def rebuild(
    dataset: RecordedDataset,
    rskill: RSkillManifest | None = None,
    view: SceneView | None = None,
    rskill_source: str | None = None,
) -> Rebuilt:
    """The recorded scene with the recorded robot, driven through `rskill`'s contract (default: the recorded one).

    Raises an OpenralError naming the scene type when that scene cannot restore a recorded initial state.
    """
    scene = _twin_scene(dataset) if dataset.hal_recording() else dataset.scene()
    view = view or SceneView()
    update: dict[str, object] = {}
    if view.cameras is not None:
        update["cameras"] = list(view.cameras)
    if view.render is not None:
        update["render"] = view.render
    if update:
        scene = scene.model_copy(update={"scene": scene.scene.model_copy(update=update)})
    source = f"{dataset.root} (the MuJoCo twin of a robot recording)" if dataset.hal_recording() else None
    source = source or dataset.scene_source()
    robot = registry.ROBOTS[dataset.robot()]
    manifest = rskill if rskill is not None else dataset.rskill()
    factory = registry.scene_factory(scene.scene.type, source)
    env = factory(scene, robot, manifest, source)
    if not env.spec.can_restore_state:
        env.close()
        raise ReplayError(
            f"{source}: scene.type: {scene.scene.type!r} scenes cannot restore a recorded initial state, so they "
            "cannot be replayed from the recorded start (use --mode policy, which needs no simulator)"
        )
    return Rebuilt(
        env=env,
        scene=scene,
        robot=robot,
        rskill=manifest,
        source=source,
        rskill_source=rskill_source or f"rSkill {manifest.id} (as recorded in {dataset.root})",
    )


def _twin_scene(dataset: RecordedDataset) -> SimScene:
    """The scene a robot recording replays in: the robot's twin at the recorded fps, with the twin's default
    cameras for the manifest's (the real cameras' poses are not known)."""
    from openral_data.producers.hal.robots.twin import twin_cameras

    robot = registry.ROBOTS[dataset.robot()]
    spec = SceneSpec(
        id="mujoco_twin", type="mujoco_twin", robot=robot.name, fps=dataset.fps, cameras=twin_cameras(robot)
    )
    rskill = dataset.rskill()
    longest = max((int(dataset.row(e)["length"]) for e in range(len(dataset))), default=1)
    task = TaskSpec(scene_id=spec.id, instruction=rskill.description or rskill.id, max_steps=max(1, longest))
    return SimScene(tier="sim", scene=spec, task=task)
