"""The geometry of a MuJoCo camera as its recorded feature's `info` carries it (and MCAP's CameraInfo / TF).

* `camera_info`: ROS `sensor_msgs/CameraInfo` fields (frame_id, width, height, distortion_model, d, k, r, p) of
  a pinhole camera without distortion: fx = fy = (H / 2) / tan(fovy / 2) (MuJoCo's pixels are square, `fovy` is
  the vertical field of view), cx = (W - 1) / 2, cy = (H - 1) / 2 (OpenCV's convention: a pixel's centre has
  integer coordinates, u to the right, v down). `frame_id` is the stream's name (the frame_id of its images).
* `intrinsics`: the same numbers by name (fx, fy, cx, cy in pixels, fovy in degrees).
* `extrinsics`: the pose of the camera's optical frame in `parent_frame`: position [x, y, z] (metres) and
  quaternion [qw, qx, qy, qz]; `convention: opencv_optical` (ROS REP 103's `_optical` frames: x right, y down,
  z forward into the scene), NOT MuJoCo's camera frame (x right, y up, looking along -z): that one is turned
  180 degrees about its x axis, and a camera whose frames the rig turns upright (`flipped`) 180 degrees about z
  as well. `parent_frame` is `world` for a camera fixed in the world, else the MuJoCo body it is mounted on (a
  wrist camera moves with it; its world pose is that body's pose times this one).

A camera whose model gives explicit sensor intrinsics (`sensorsize`) or that tracks a body (`mode` other than
fixed) has no geometry here (None): its stream is recorded without it.
"""

from __future__ import annotations

import math
from typing import Any

import mujoco
import numpy as np
import numpy.typing as npt

WORLD = "world"
CONVENTION = "opencv_optical"
# MuJoCo camera axes -> optical axes: 180 degrees about x (y up -> down, -z forward -> +z forward)
_TO_OPTICAL = np.diag([1.0, -1.0, -1.0])
_TURNED = np.diag([-1.0, -1.0, 1.0])  # an image turned 180 degrees: 180 degrees about the optical z axis


def intrinsics(width: int, height: int, fovy_deg: float) -> tuple[float, float, float, float]:
    """(fx, fy, cx, cy) in pixels of a MuJoCo camera rendering `width` x `height` with vertical fov `fovy_deg`."""
    f = (height / 2.0) / math.tan(math.radians(fovy_deg) / 2.0)
    return f, f, (width - 1) / 2.0, (height - 1) / 2.0


def _quat(mat: npt.NDArray[np.float64]) -> list[float]:
    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(mat).reshape(-1))
    if q[0] < 0:
        q = -q
    return [float(v) for v in q]


def camera_geometry(
    model: mujoco.MjModel, camera: str, width: int, height: int, frame_id: str, flipped: bool = False
) -> dict[str, Any] | None:
    """The `camera_info`, `intrinsics` and `extrinsics` entries of camera `camera`'s feature info (see above)."""
    cid = int(model.camera(camera).id)
    if np.any(model.cam_sensorsize[cid] > 0) or int(model.cam_mode[cid]) != int(mujoco.mjtCamLight.mjCAMLIGHT_FIXED):
        return None
    fx, fy, cx, cy = intrinsics(width, height, float(model.cam_fovy[cid]))
    body = int(model.cam_bodyid[cid])
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, np.asarray(model.cam_quat[cid], dtype=np.float64))
    optical = rot.reshape(3, 3) @ _TO_OPTICAL @ (_TURNED if flipped else np.eye(3))
    return {
        "camera_info": {
            "frame_id": frame_id,
            "width": width,
            "height": height,
            "distortion_model": "plumb_bob",
            "d": [0.0] * 5,
            "k": [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0],
            "r": [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0],
            "p": [fx, 0.0, cx, 0.0, 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0],
        },
        "intrinsics": {"fx": fx, "fy": fy, "cx": cx, "cy": cy, "fovy": float(model.cam_fovy[cid])},
        "extrinsics": {
            "parent_frame": WORLD if body == 0 else str(model.body(body).name),
            "position": [float(v) for v in model.cam_pos[cid]],
            "quaternion": _quat(optical),
            "convention": CONVENTION,
        },
    }


def project(info: dict[str, Any], point: npt.ArrayLike) -> tuple[float, float]:
    """The pixel (u, v) where a world point appears in a world-fixed camera of feature info `info` (the
    inverse of what the geometry promises; tests and users check a camera with it)."""
    ext, k = info["extrinsics"], info["intrinsics"]
    rot = np.zeros(9)
    mujoco.mju_quat2Mat(rot, np.asarray(ext["quaternion"], dtype=np.float64))
    p = rot.reshape(3, 3).T @ (np.asarray(point, dtype=np.float64) - np.asarray(ext["position"], dtype=np.float64))
    return float(k["fx"] * p[0] / p[2] + k["cx"]), float(k["fy"] * p[1] / p[2] + k["cy"])
