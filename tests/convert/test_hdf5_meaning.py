"""What an HDF5 source's data means survives `convert` (#45): a dataset that is not a per-step array of its
episode (robosuite 1.4's `controller_info/*` teleop log: more rows than steps) is listed as ignored by `info`, not
read, and blocks neither `--print-mapping` nor a conversion that does not map it; a mapping that names it is told
why."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pyarrow.parquet as pq

from tests.support.hdf5_layouts import write_robomimic
from tests.support.inproc import run_inproc
from tests.support.scenes import write_yaml


def _with_teleop_log(path: Path) -> Path:
    """robosuite 1.4.1's two-arm demos log the controller per control substep: 2 rows a step here (ragged)."""
    write_robomimic(path, lengths=(4, 3))
    with h5py.File(path, "a") as f:
        for e, n in enumerate((4, 3)):
            f.create_dataset(f"data/demo_{e}/controller_info/counters", data=np.arange(2 * n + 1))
    return path


def test_an_unmapped_ragged_group_is_ignored(tmp_path: Path) -> None:
    src = _with_teleop_log(tmp_path / "handover.hdf5")
    info = run_inproc("info", str(src), "--json")
    assert info.returncode == 0, info.stderr
    ignored = json.loads(info.stdout)["ignored"]
    assert ignored == {"controller_info/counters": "9 rows, the episode has 4 steps (ragged)"}
    assert "controller_info/counters" not in {a["key"] for a in json.loads(info.stdout)["arrays"]}
    printed = run_inproc("convert", str(src), "--print-mapping")
    assert printed.returncode == 0 and "controller_info" not in printed.stdout, printed.stderr
    mapping = {"fps": 20, "task": "handover", "state": {"topic": "states"}, "action": {"topic": "actions"}}
    out = tmp_path / "out"
    run = run_inproc("convert", str(src), str(out), "--mapping", str(write_yaml(tmp_path / "m.yaml", mapping)))
    assert run.returncode == 0, run.stderr
    table = pq.read_table(out / "data").sort_by("index").to_pydict()
    with h5py.File(src, "r") as f:
        want = np.concatenate([f[f"data/demo_{e}/actions"][...] for e in range(2)])
    assert table["action"] == want.astype(np.float32).tolist()


def test_a_mapping_that_names_it_is_told_why(tmp_path: Path) -> None:
    src = _with_teleop_log(tmp_path / "handover.hdf5")
    mapping = {"fps": 20, "task": "handover", "state": {"topic": "controller_info/counters"},
               "action": {"topic": "actions"}}  # fmt: skip
    out = tmp_path / "out"
    run = run_inproc("convert", str(src), str(out), "--mapping", str(write_yaml(tmp_path / "m.yaml", mapping)))
    assert run.returncode == 2 and not out.exists()
    assert "demo_0/controller_info/counters: state: not a per-step array: 9 rows" in run.stderr
