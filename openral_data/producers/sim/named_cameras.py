"""Offscreen rendering of the cameras a wrapped simulator's model already defines (robosuite, MetaWorld).

The scene YAML names the model's cameras and picks each one's resolution; `pos`/`lookat`/`mount` placement is
for composed scenes and is refused here. Frames come out upright: MuJoCo renders in the camera's own frame,
and a camera whose "up" axis points below the horizon (MetaWorld's `corner2`, for one) is turned 180 degrees.
Shadows and reflections follow the YAML's `render:` block (off by default: they dominate CPU render time); the
adapter says which geom groups are drawn.
"""

from __future__ import annotations

import mujoco
import numpy as np
import numpy.typing as npt

from openral_data.errors import ConfigError
from openral_data.producers.sim.mujoco.render import offscreen_renderer
from openral_data.schemas.scene import RenderConfig, SceneCamera


def camera_names(model: mujoco.MjModel) -> list[str]:
    return [model.camera(i).name for i in range(model.ncam)]


class NamedCameraRig:
    """One `mujoco.Renderer` per camera; `close()` frees their GL contexts."""

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        cameras: list[SceneCamera],
        render: RenderConfig,
        source: str,
        geom_groups: tuple[int, ...] | None = None,
    ) -> None:
        valid = camera_names(model)
        for k, cam in enumerate(cameras):
            where = f"{source}: scene.cameras[{k}]"
            if cam.name not in valid:
                raise ConfigError(f"{where}.name: no camera {cam.name!r} in this simulator; valid: {', '.join(valid)}")
            if cam.pos is not None or cam.lookat is not None or cam.mount != "world":
                raise ConfigError(
                    f"{where}: pos/lookat/mount place cameras in composed scenes; here name a model camera"
                )
        self._option = mujoco.MjvOption()
        self._option.sitegroup[:] = 0
        if geom_groups is not None:  # else MuJoCo's default (groups 0-2 drawn)
            self._option.geomgroup[:] = 0
            for g in geom_groups:
                self._option.geomgroup[g] = 1
        self._renderers: dict[str, mujoco.Renderer] = {}
        self._flip: dict[str, bool] = {}
        mujoco.mj_forward(model, data)
        try:
            for cam in cameras:
                self._renderers[cam.name] = offscreen_renderer(model, cam, render)
                self._flip[cam.name] = upside_down(model, data, cam.name)
        except BaseException:
            self.close()
            raise

    def render(self, data: mujoco.MjData) -> dict[str, npt.NDArray[np.uint8]]:
        out: dict[str, npt.NDArray[np.uint8]] = {}
        for name, r in self._renderers.items():
            r.update_scene(data, camera=name, scene_option=self._option)
            img = r.render()
            out[name] = np.ascontiguousarray(img[::-1, ::-1]) if self._flip[name] else img.copy()
        return out

    def close(self) -> None:
        for r in self._renderers.values():
            r.close()
        self._renderers.clear()


def upside_down(model: mujoco.MjModel, data: mujoco.MjData, name: str) -> bool:
    """True when the camera's image "up" direction (its frame's y axis) points downwards in the world."""
    xmat = data.cam_xmat[model.camera(name).id].reshape(3, 3)
    return bool(xmat[2, 1] < -1e-6)
