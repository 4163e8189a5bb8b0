"""The dataset schema of a run: the rSkill's contract, the source's rate and cameras, and the provenance metadata
(`meta/openral.json` in LeRobot v3, an `Origin`) every tool that records writes the same way: `record` (a sim
scene), `record --hal` (a robot behind its HAL) and `replay --record`."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

from openral_data.errors import ConfigError
from openral_data.formats.lerobot_v3.provenance import Origin, Recorded, ReplayOrigin
from openral_data.schemas.robot import RobotManifest
from openral_data.schemas.rskill import RSkillManifest
from openral_data.schemas.scene import SimScene
from openral_data.types import CameraShape, DatasetSchema, FrameColumn, ProducerSpec
from openral_data.version import __version__


def dataset_schema(
    robot: RobotManifest,
    rskill: RSkillManifest,
    rskill_source: str,
    *,
    fps: int,
    cameras: Mapping[str, CameraShape],
    origin: Origin,
    environment_state_names: tuple[str, ...] = (),
    has_reward: bool = True,
    frame_extras: tuple[str, ...] = (),
    frame_columns: tuple[FrameColumn, ...] = (),
) -> DatasetSchema:
    """`origin`: what produced the frames (its `scene` or `hal`, and `safety`/`replayed_from` where they apply);
    the version, the rSkill and the robot are filled in here."""
    metadata = dataclasses.replace(
        origin,
        openral_data_version=__version__,
        rskill=Recorded(rskill_source, rskill.model_dump(mode="json")),
        robot=robot.name,
    )
    return DatasetSchema(
        fps=fps,
        state_names=tuple(rskill.state_contract.names),
        action_names=tuple(rskill.action_contract.names),
        cameras=dict(cameras),
        robot_type=robot.name,
        environment_state_names=environment_state_names,
        metadata=metadata.to_json(),
        has_reward=has_reward,
        frame_extras=frame_extras,
        frame_columns=frame_columns,
    )


def check_environment_state(scene: SimScene, scene_source: str, spec: ProducerSpec) -> None:
    """A scene that declares `observations.environment_state` must be of a type that reports its object poses
    (`spec.environment_state_names`), whether `record --scene` or the HAL (`record --hal --scene`) runs it."""
    if scene.scene.observations.environment_state and not spec.environment_state_names:
        raise ConfigError(
            f"{scene_source}: scene.observations.environment_state: scene type {scene.scene.type!r} "
            "reports no object poses"
        )


def scene_schema(
    spec: ProducerSpec,
    scene: SimScene,
    scene_source: str,
    robot: RobotManifest,
    rskill: RSkillManifest,
    rskill_source: str,
    replayed_from: ReplayOrigin | None = None,
) -> DatasetSchema:
    """The schema of a sim scene's rollouts (`record`, `replay --record`): its rate, cameras and object poses."""
    return dataset_schema(
        robot,
        rskill,
        rskill_source,
        fps=spec.fps,
        cameras=spec.cameras,
        origin=Origin(scene=Recorded(scene_source, scene.model_dump(mode="json")), replayed_from=replayed_from),
        environment_state_names=spec.environment_state_names,
    )
