"""Offscreen cameras: one `mujoco.Renderer` per camera, shadows/reflections per the scene's render config.

Sites (the grasp markers of robot MJCFs) are hidden. The robot is drawn with its collision meshes (geom group
0) or its visual meshes (group 1) per `render.robot_meshes`; the scene's own geoms are group 2 and always drawn.
A simulator's own cameras are rendered by the same rig (named_cameras.py builds it with their flips).
A camera with `depth: true` also gives its depth map, `<name>_depth`: float32 metres along the optical axis
(MuJoCo's `enable_depth_rendering`, the same scene update as its colour frame); where nothing is hit (the far
plane) it is +inf, REP 118's "no return" (a lerobot depth video loads it as its `depth_max`).
A camera with `segmentation: true` also gives its mask, `<name>_segmentation`: (H, W) uint16 object ids
(segmentation.py; MuJoCo's `enable_segmentation_rendering`, the same scene update), the id -> name table in its
shape's `info["segmentation_ids"]`.
`mount_poses()` is the world pose of each body a camera is mounted on (a wrist camera's: MCAP's per-frame /tf).
`shapes()` is every stream's CameraShape with the camera's geometry (camera_geometry.py) in its info.
Renderers hold GL contexts: `close()` frees them.
"""

from __future__ import annotations

from collections.abc import Collection
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

from openral_data.producers.sim.mujoco.camera_geometry import WORLD, camera_geometry
from openral_data.producers.sim.mujoco.objects import SCENE_GROUP
from openral_data.producers.sim.mujoco.segmentation import segmenter
from openral_data.schemas.scene import RenderConfig, SceneCamera, depth_camera_name, segmentation_camera_name
from openral_data.types import CameraShape

FAR_PLANE_FRACTION = 0.999  # depth at the far plane (within float32 rounding) is "nothing hit"


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
        self._far = FAR_PLANE_FRACTION * float(model.vis.map.zfar * model.stat.extent)
        self._depth = {cam.name: depth_camera_name(cam.name) for cam in cameras if cam.depth}
        self._masks = {cam.name: segmentation_camera_name(cam.name) for cam in cameras if cam.segmentation}
        self._segmenter = segmenter(model) if self._masks else None
        self._shapes: dict[str, CameraShape] = {}
        for cam in cameras:
            flip = cam.name in self._flipped
            self._shapes[cam.name] = CameraShape(
                cam.height,
                cam.width,
                info=camera_geometry(model, cam.name, cam.width, cam.height, cam.name, flip) or {},
            )
            if cam.depth:
                depth = self._depth[cam.name]
                geometry = camera_geometry(model, cam.name, cam.width, cam.height, depth, flip)
                self._shapes[depth] = CameraShape(cam.height, cam.width, depth_unit="m", info=geometry or {})
            if self._segmenter is not None and cam.segmentation:
                mask = self._masks[cam.name]
                geometry = camera_geometry(model, cam.name, cam.width, cam.height, mask, flip) or {}
                info = {**geometry, "segmentation_ids": self._segmenter.info()}
                self._shapes[mask] = CameraShape(cam.height, cam.width, segmentation=True, info=info)
        parents = {str(s.info["extrinsics"]["parent_frame"]) for s in self._shapes.values() if "extrinsics" in s.info}
        bodies = {p: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, p) for p in sorted(parents - {WORLD}) if p}
        self._mounts = {p: body for p, body in bodies.items() if body > 0}
        self._renderers: dict[str, mujoco.Renderer] = {}
        try:
            for cam in cameras:
                self._renderers[cam.name] = offscreen_renderer(model, cam, render)
        except BaseException:
            self.close()
            raise

    def shapes(self) -> dict[str, CameraShape]:
        """Every stream the rig renders (a camera, then its depth map and mask if asked), with its geometry in
        `info`."""
        return dict(self._shapes)

    def mount_poses(self, data: mujoco.MjData) -> dict[str, npt.NDArray[np.float64]]:
        """The world pose [x, y, z, qw, qx, qy, qz] of every body a camera is mounted on (its extrinsics'
        `parent_frame` other than `world`), as `data` has it (the state the frames are rendered from)."""
        return {
            name: np.concatenate([data.xpos[body], data.xquat[body]]).astype(np.float64)
            for name, body in self._mounts.items()
        }

    def render(self, data: mujoco.MjData) -> dict[str, npt.NDArray[Any]]:
        """Colour frames (uint8 HWC); a depth stream's entry is float32 (H, W) metres, a mask's (H, W) uint16 ids
        (see `shapes()`)."""
        out: dict[str, npt.NDArray[Any]] = {}
        for name, r in self._renderers.items():
            r.update_scene(data, camera=name, scene_option=self._option)
            out[name] = self._upright(name, r.render())
            depth = self._depth.get(name)
            if depth is not None:
                r.enable_depth_rendering()
                try:
                    metres = self._upright(name, r.render())
                    metres[metres >= self._far] = np.inf
                    out[depth] = metres
                finally:
                    r.disable_depth_rendering()
            mask = self._masks.get(name)
            if mask is not None and self._segmenter is not None:
                r.enable_segmentation_rendering()
                try:
                    out[mask] = self._upright(name, self._segmenter.mask(r.render()))
                finally:
                    r.disable_segmentation_rendering()
        return out

    def _upright(self, name: str, img: npt.NDArray[Any]) -> npt.NDArray[Any]:
        return np.ascontiguousarray(img[::-1, ::-1]) if name in self._flipped else img.copy()

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
