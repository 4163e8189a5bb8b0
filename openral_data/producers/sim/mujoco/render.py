"""Offscreen cameras: one `mujoco.Renderer` per camera, shadows/reflections per the scene's render config.

Sites (the grasp markers of robot MJCFs) are hidden. The robot is drawn with its collision meshes (geom group
0) or its visual meshes (group 1) per `render.robot_meshes`; the scene's own geoms are group 2 and always drawn.
A simulator's own cameras are rendered by the same rig (named_cameras.py builds it with their flips).
Renderers hold GL contexts: `close()` frees them.
"""

from __future__ import annotations

from collections.abc import Collection

import mujoco
import numpy as np
import numpy.typing as npt

from openral_data.producers.sim.mujoco.objects import SCENE_GROUP
from openral_data.schemas.scene import RenderConfig, SceneCamera


class CameraRig:
    """`option` replaces the composed scenes' geom/site groups (a simulator's own MJCF keeps MuJoCo's defaults);
    the cameras named in `flipped` are turned 180 degrees (so that frames come out upright)."""

    def __init__(
        self,
        model: mujoco.MjModel,
        cameras: list[SceneCamera],
        render: RenderConfig,
        option: mujoco.MjvOption | None = None,
        flipped: Collection[str] = (),
    ) -> None:
        if option is None:
            option = mujoco.MjvOption()
            option.sitegroup[:] = 0
            option.geomgroup[:] = 0
            option.geomgroup[0 if render.robot_meshes == "collision" else 1] = 1
            option.geomgroup[SCENE_GROUP] = 1
        self._option = option
        self._flipped = frozenset(flipped)
        self._renderers: dict[str, mujoco.Renderer] = {}
        try:
            for cam in cameras:
                self._renderers[cam.name] = offscreen_renderer(model, cam, render)
        except BaseException:
            self.close()
            raise

    def render(self, data: mujoco.MjData) -> dict[str, npt.NDArray[np.uint8]]:
        out: dict[str, npt.NDArray[np.uint8]] = {}
        for name, r in self._renderers.items():
            r.update_scene(data, camera=name, scene_option=self._option)
            img = r.render()
            out[name] = np.ascontiguousarray(img[::-1, ::-1]) if name in self._flipped else img.copy()
        return out

    def close(self) -> None:
        for r in self._renderers.values():
            r.close()
        self._renderers.clear()


def offscreen_renderer(model: mujoco.MjModel, cam: SceneCamera, render: RenderConfig) -> mujoco.Renderer:
    """A renderer of the camera's size with the scene's shadow/reflection choice."""
    r = mujoco.Renderer(model, height=cam.height, width=cam.width)
    r.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = render.shadows
    r.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = render.reflections
    return r
