"""Snapshots of a wrapped simulator's MuJoCo state, as JSON, for `initial_state()` / `reset_to()`.

A snapshot holds MuJoCo's full integration state (`mj_getState(mjSTATE_INTEGRATION)`: time, qpos, qvel, act,
warm-start accelerations, controls, applied forces, mocap poses, ...) plus the model's body poses, because
suites such as robosuite's Door place objects by editing `model.body_pos` rather than a joint.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from openral_data.errors import ConfigError

_SPEC = mujoco.mjtState.mjSTATE_INTEGRATION


def snapshot(model: mujoco.MjModel, data: mujoco.MjData) -> dict[str, Any]:
    state = np.empty(mujoco.mj_stateSize(model, _SPEC), dtype=np.float64)
    mujoco.mj_getState(model, data, state, _SPEC)
    return {
        "integration_state": state.tolist(),
        "body_pos": model.body_pos.tolist(),
        "body_quat": model.body_quat.tolist(),
    }


def restore(model: mujoco.MjModel, data: mujoco.MjData, snap: dict[str, Any], source: str) -> None:
    """Write a snapshot back (ConfigError naming `source` if it was taken on another model).

    mj_forward recomputes the derived quantities but also overwrites the solver's warm start, which the next
    step depends on, so the state is written once more afterwards.
    """
    try:
        state = np.asarray(snap["integration_state"], dtype=np.float64)
        body_pos = np.asarray(snap["body_pos"], dtype=np.float64)
        body_quat = np.asarray(snap["body_quat"], dtype=np.float64)
    except (KeyError, TypeError, ValueError) as exc:
        raise ConfigError(f"{source}: not a MuJoCo snapshot: {exc}") from None
    if state.shape != (mujoco.mj_stateSize(model, _SPEC),) or body_pos.shape != model.body_pos.shape:
        raise ConfigError(f"{source}: the snapshot was taken on a different model (sizes do not match this scene)")
    model.body_pos[...] = body_pos
    model.body_quat[...] = body_quat.reshape(model.body_quat.shape)
    mujoco.mj_setState(model, data, state, _SPEC)
    mujoco.mj_forward(model, data)
    mujoco.mj_setState(model, data, state, _SPEC)


def same_state(a: dict[str, Any], b: dict[str, Any]) -> bool:
    """Bit-for-bit equality of two snapshots."""
    keys = ("integration_state", "body_pos", "body_quat")
    return all(k in a and k in b and np.array_equal(np.asarray(a[k]), np.asarray(b[k])) for k in keys)
