"""Segmentation masks of a MuJoCo model: which object each pixel shows, as stable per-scene ids.

MuJoCo's segmentation rendering (`mujoco.Renderer.enable_segmentation_rendering`) gives per pixel the id and type
of the object drawn there (-1 where nothing is). A mask maps that to an object id of the scene: every geom
belongs to the object that is its body's top-level body (the child of the world it hangs from: `cube`, `goal`,
the robot's root body with its gripper), geoms of the world body itself are named by the geom (`table`, `floor`;
`world` if unnamed). Ids count from 1 in the order of the model's geoms (the model is the same for every episode
of a scene, so the ids are too); 0 is the background (nothing drawn, or something that is not a geom).
`labels` is {id: name} with 0 = `background`, as a mask feature's `info["segmentation_ids"]` lists it.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import numpy.typing as npt

BACKGROUND = "background"


@dataclass(frozen=True)
class Segmenter:
    """A model's geom -> object id table (`geom_ids[g]`) and the object names (`labels`)."""

    geom_ids: npt.NDArray[np.uint16]
    labels: dict[int, str]

    def mask(self, rendered: npt.NDArray[np.int32]) -> npt.NDArray[np.uint16]:
        """The (H, W) uint16 object ids of MuJoCo's (H, W, 2) segmentation render (object id, object type)."""
        objid, objtype = rendered[..., 0], rendered[..., 1]
        is_geom = (objtype == int(mujoco.mjtObj.mjOBJ_GEOM)) & (objid >= 0) & (objid < len(self.geom_ids))
        out = np.zeros(objid.shape, dtype=np.uint16)
        out[is_geom] = self.geom_ids[objid[is_geom]]
        return out

    def info(self) -> dict[str, str]:
        """The labels as JSON keeps them: {"<id>": name}."""
        return {str(i): name for i, name in sorted(self.labels.items())}


def object_name(model: mujoco.MjModel, geom: int) -> str:
    """The object geom `geom` belongs to: its top-level body's name, or for a world geom the geom's name."""
    root = int(model.body_rootid[model.geom_bodyid[geom]])
    if root == 0:
        return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, geom) or "world"
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, root) or f"body{root}"


def segmenter(model: mujoco.MjModel) -> Segmenter:
    """The object ids of `model`'s geoms (see the module docstring)."""
    ids: dict[str, int] = {}
    geom_ids = np.zeros(model.ngeom, dtype=np.uint16)
    for g in range(model.ngeom):
        geom_ids[g] = ids.setdefault(object_name(model, g), len(ids) + 1)
    return Segmenter(geom_ids, {0: BACKGROUND, **{i: name for name, i in ids.items()}})
