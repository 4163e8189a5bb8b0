"""Snapshots of a wrapped simulator's MuJoCo state, as JSON, for `initial_state()` / `reset_to()`.

Wrapped suites (robosuite, MetaWorld) keep task and controller state in Python next to MuJoCo's, so they restore a
recorded start by repeating its seeded reset and checking, with `same_state`, that it lands on the recorded
snapshot bit for bit (writing a state back does not reproduce later steps exactly for every task).

A snapshot holds MuJoCo's full integration state (`mj_getState(mjSTATE_INTEGRATION)`: time, qpos, qvel, act,
warm-start accelerations, controls, applied forces, mocap poses, ...) plus the model's body poses, because
suites such as robosuite's Door place objects by editing `model.body_pos` rather than a joint.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

_SPEC = mujoco.mjtState.mjSTATE_INTEGRATION


def snapshot(model: mujoco.MjModel, data: mujoco.MjData) -> dict[str, Any]:
    state = np.empty(mujoco.mj_stateSize(model, _SPEC), dtype=np.float64)
    mujoco.mj_getState(model, data, state, _SPEC)
    return {
        "integration_state": state.tolist(),
        "body_pos": model.body_pos.tolist(),
        "body_quat": model.body_quat.tolist(),
    }


def same_state(a: dict[str, Any], b: dict[str, Any]) -> bool:
    """Bit-for-bit equality of two snapshots."""
    keys = ("integration_state", "body_pos", "body_quat")
    return all(k in a and k in b and np.array_equal(np.asarray(a[k]), np.asarray(b[k])) for k in keys)
