"""A demo.hdf5 written by robosuite's own writer (`robosuite.scripts.collect_human_demonstrations.
gather_demonstrations_as_hdf5` over `DataCollectionWrapper` episodes of a real Lift env, robosuite 1.5.1; the
success check forced so random-action episodes are kept) converts with the built-in mapping: state = the
flattened MuJoCo states, action = actions, task = the env name, values equal to the file read by h5py."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pyarrow.parquet as pq
import pytest

from tests.support.inproc import run_inproc


def _robosuite_demo(tmp: Path) -> Path:
    import robosuite as suite
    from robosuite.scripts.collect_human_demonstrations import gather_demonstrations_as_hdf5
    from robosuite.wrappers import DataCollectionWrapper

    raw, out = tmp / "raw", tmp / "demos"
    out.mkdir()
    env = suite.make("Lift", robots="Panda", has_renderer=False, has_offscreen_renderer=False,
                     use_camera_obs=False, control_freq=20)  # fmt: skip
    env._check_success = lambda: True  # gather keeps successful demonstrations only
    env = DataCollectionWrapper(env, str(raw))
    rng = np.random.default_rng(0)
    for ep in range(2):
        env.reset()
        for _ in range(6 + 3 * ep):
            env.step(rng.uniform(-0.2, 0.2, env.action_dim))
    env.close()
    gather_demonstrations_as_hdf5(str(raw), str(out), json.dumps({"env_name": "Lift"}))
    return out / "demo.hdf5"


@pytest.mark.slow  # a real robosuite env is built and stepped
def test_robosuite_demo_hdf5_converts(tmp_path: Path) -> None:
    src = _robosuite_demo(tmp_path)
    out = tmp_path / "out"
    refused = run_inproc("convert", str(src), str(out), "--codec", "h264")
    assert refused.returncode == 2 and "fps: the source declares no step rate" in refused.stderr
    run = run_inproc("convert", str(src), str(out), "--codec", "h264", "--fps", "20")
    assert run.returncode == 0, run.stderr
    table = pq.read_table(out / "data").sort_by("index").to_pydict()
    with h5py.File(src, "r") as f:
        demos = sorted(f["data"], key=lambda n: int(n.split("_")[1]))
        states = np.concatenate([f[f"data/{d}/states"][...] for d in demos])
        actions = np.concatenate([f[f"data/{d}/actions"][...] for d in demos])
    assert table["observation.state"] == states.astype(np.float32).tolist()
    assert table["action"] == actions.astype(np.float32).tolist()
    assert "Lift" in str(pq.read_table(out / "meta/tasks.parquet").to_pydict())
