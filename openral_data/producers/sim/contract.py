"""What a simulated scene promises: its ProducerSpec (every simulated scene can restore a recorded initial state),
and the rSkill contract checks it makes: is the skill's state/action representation one the scene
produces/accepts? One refusal shape, `<rskill>: <side>_contract.representation: <why>`, for all of them.

`observation.environment_state` of a simulated scene (`scene.observations.environment_state`) is its objects'
poses: per object `<object>.x, .y, .z, .qw, .qx, .qy, .qz` (world frame), in the order the scene names them,
from `Observation.privileged["object_poses"]` (`object_pose_names` / `object_pose_vector`)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from openral_data.errors import CompatibilityError, ConfigError
from openral_data.schemas.rskill import RSkillManifest
from openral_data.schemas.scene import SceneCamera
from openral_data.types import CameraShape, ProducerSpec

Side = Literal["state", "action"]


POSE_FIELDS = ("x", "y", "z", "qw", "qx", "qy", "qz")


def scene_spec(
    state_dim: int | None,
    action_dim: int | None,
    cameras: Iterable[SceneCamera],
    fps: int,
    *,
    shapes: Mapping[str, CameraShape] | None = None,
    environment_objects: Sequence[str] = (),
    source: str = "scene",
) -> ProducerSpec:
    """The spec of a simulated scene rendering `cameras` at their YAML sizes; `None` dims mean "any".

    `shapes`: every stream the scene renders with its geometry (`CameraRig.shapes()`, depth and segmentation
    streams included); without them the scene renders colour only and a camera asking for depth or segmentation
    is refused. `environment_objects`: the objects whose poses `observation.environment_state` carries (empty:
    none)."""
    cams = list(cameras)
    if shapes is None:
        for i, c in enumerate(cams):
            if c.depth:
                raise ConfigError(f"{source}: scene.cameras[{i}].depth: this scene type renders no depth")
            if c.segmentation:
                raise ConfigError(f"{source}: scene.cameras[{i}].segmentation: this scene type renders no segmentation")
        shapes = {c.name: CameraShape(c.height, c.width) for c in cams}
    return ProducerSpec(
        state_dim=state_dim,
        action_dim=action_dim,
        cameras=dict(shapes),
        fps=fps,
        can_restore_state=True,
        environment_state_names=object_pose_names(environment_objects),
    )


def object_pose_names(objects: Iterable[str]) -> tuple[str, ...]:
    """`observation.environment_state`'s names for the poses of `objects`: `<object>.x` ... `<object>.qz`."""
    return tuple(f"{o}.{f}" for o in objects for f in POSE_FIELDS)


def object_pose_vector(poses: Mapping[str, Any], objects: Sequence[str]) -> npt.NDArray[np.float32]:
    """`observation.environment_state` from `privileged["object_poses"]` ({object: [x, y, z, qw, qx, qy, qz]})."""
    if not objects:
        return np.zeros(0, dtype=np.float32)
    return np.concatenate([np.asarray(poses[o], dtype=np.float32).reshape(7) for o in objects])


def check_representation(rskill_source: str, side: Side, representation: str, valid: Sequence[str], why: str) -> None:
    """CompatibilityError `why` (the scene's own words) unless `representation` is one of `valid`."""
    if representation not in valid:
        raise CompatibilityError(f"{rskill_source}: {side}_contract.representation: {why}")


def check_representations(
    rskill: RSkillManifest,
    rskill_source: str,
    scene_label: str,
    produced: Sequence[str],
    accepted: Sequence[str],
    accepted_note: str = "",
) -> None:
    """The skill's state representation must be one the scene produces, its action one the scene accepts
    (`accepted_note` follows the accepted list in the message, e.g. what those actions mean)."""
    state = rskill.state_contract.representation
    action = rskill.action_contract.representation
    check_representation(
        rskill_source,
        "state",
        state,
        produced,
        f"{state!r} is not produced by {scene_label} (they produce {', '.join(produced)})",
    )
    check_representation(
        rskill_source,
        "action",
        action,
        accepted,
        f"{action!r} is not accepted by {scene_label} (they accept {', '.join(accepted)}{accepted_note})",
    )
