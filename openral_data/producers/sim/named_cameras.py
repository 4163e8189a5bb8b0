"""Offscreen rendering of the cameras a wrapped simulator's model already defines (robosuite, MetaWorld).

The scene YAML names the model's cameras and picks each one's resolution; `pos`/`lookat`/`mount` placement is
for composed scenes and is refused here. Frames come out upright: MuJoCo renders in the camera's own frame,
and a camera whose "up" axis points below the horizon (MetaWorld's `corner2`, for one) is turned 180 degrees.
Shadows and reflections follow the YAML's `render:` block (off by default: they dominate CPU render time); the
adapter says which geom groups are drawn. The renderers are mujoco/render.py's CameraRig.
"""

from __future__ import annotations

import mujoco

from openral_data.producers.sim.external import check_cameras
from openral_data.producers.sim.mujoco.render import CameraRig
from openral_data.schemas.scene import RenderConfig, SceneCamera


def camera_names(model: mujoco.MjModel) -> list[str]:
    return [model.camera(i).name for i in range(model.ncam)]


def named_camera_rig(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    cameras: list[SceneCamera],
    render: RenderConfig,
    source: str,
    geom_groups: tuple[int, ...] | None = None,
) -> CameraRig:
    """A CameraRig over the model's own cameras, sites hidden, upside-down cameras flipped; `close()` frees it."""
    check_cameras(
        cameras,
        camera_names(model),
        source,
        unknown="{where}.name: no camera {name!r} in this simulator; valid: {valid}",
        placed="{where}: pos/lookat/mount place cameras in composed scenes; here name a model camera",
    )
    option = mujoco.MjvOption()
    option.sitegroup[:] = 0
    if geom_groups is not None:  # else MuJoCo's default (groups 0-2 drawn)
        option.geomgroup[:] = 0
        for g in geom_groups:
            option.geomgroup[g] = 1
    mujoco.mj_forward(model, data)
    flipped = [cam.name for cam in cameras if upside_down(model, data, cam.name)]
    return CameraRig(model, cameras, render, option=option, flipped=flipped)


def upside_down(model: mujoco.MjModel, data: mujoco.MjData, name: str) -> bool:
    """True when the camera's image "up" direction (its frame's y axis) points downwards in the world."""
    xmat = data.cam_xmat[model.camera(name).id].reshape(3, 3)
    return bool(xmat[2, 1] < -1e-6)
