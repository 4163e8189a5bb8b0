"""Native MuJoCo scenes: manifest-driven composition (MjSpec), servo/IK control, offscreen rendering, and the
SimRollout part every MuJoCo-rendered scene shares (rig_scene.py).

Rendering is headless: MUJOCO_GL defaults to `egl`, falling back to `osmesa` when no EGL library is
installed (the variable must be set before `mujoco` is first imported, so it is decided here).
"""

from __future__ import annotations

import ctypes.util
import os

if "MUJOCO_GL" not in os.environ:
    os.environ["MUJOCO_GL"] = (
        "egl" if ctypes.util.find_library("EGL") or not ctypes.util.find_library("OSMesa") else "osmesa"
    )
