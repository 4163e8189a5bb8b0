"""Array sources take the bags' mapping file (array keys for topics): `convert SRC --print-mapping` prints the
starting mapping with its guesses marked, and converting with it as `--mapping` gives the dataset `convert`
writes with no mapping; a hand-written mapping picks keys, a fixed task and success from rewards; `--workers 2`
over a folder of HDF5 files writes what one process writes."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pyarrow.parquet as pq
import pytest
import yaml

from tests.support.hdf5_layouts import write_aloha, write_robomimic
from tests.support.inproc import run_inproc
from tests.support.scenes import write_yaml

COLUMNS = ["observation.state", "action", "episode_index", "frame_index", "task_index", "index"]


def _table(root: Path, columns: list[str] = COLUMNS) -> dict[str, list[object]]:
    return pq.read_table(root / "data", columns=columns).sort_by("index").to_pydict()


def test_print_mapping_round_trips(tmp_path: Path) -> None:
    src = write_aloha(tmp_path / "cube", lengths=(4, 3))
    printed = run_inproc("convert", str(src), "--print-mapping")
    assert printed.returncode == 0, printed.stderr
    assert "# guess: ACT / ALOHA record at 50 Hz" in printed.stdout and "# guess: the folder's name" in printed.stdout
    data = yaml.safe_load(printed.stdout)
    assert data["fps"] == 50 and data["state"]["topic"] == "observations/qpos"
    assert data["cameras"] == {"angle": "observations/images/angle", "top": "observations/images/top"}
    as_json = run_inproc("convert", str(src), "--print-mapping", "--json")
    doc = json.loads(as_json.stdout)
    assert doc["layout"] == "aloha" and doc["mapping"] == data and set(doc["guesses"]) == {"fps", "task", "state"}
    mapping = tmp_path / "m.yaml"
    mapping.write_text(printed.stdout)
    a, b = tmp_path / "a", tmp_path / "b"
    assert run_inproc("convert", str(src), str(a), "--mapping", str(mapping), "--codec", "h264").returncode == 0
    assert run_inproc("convert", str(src), str(b), "--fps", "50", "--codec", "h264").returncode == 0
    assert _table(a) == _table(b)


def test_hand_written_mapping(tmp_path: Path) -> None:
    src = write_robomimic(tmp_path / "lift.hdf5")
    mapping = write_yaml(tmp_path / "m.yaml", {
        "fps": 10,
        "task": "lift the cube",
        "state": {"topic": "obs/robot0_gripper_qpos"},
        "action": {"parts": [{"topic": "actions", "names": [f"a{i}" for i in range(7)]}]},
        "cameras": {"front": "obs/agentview_image"},
        "success": {"topic": "rewards"},
    })  # fmt: skip
    out = tmp_path / "out"
    run = run_inproc("convert", str(src), str(out), "--mapping", str(mapping), "--codec", "h264", "--json")
    assert run.returncode == 0, run.stderr
    doc = json.loads(run.stdout)
    assert doc["direction"] == "arrays-to-lerobot" and doc["layout"] == "robomimic" and doc["fps"] == 10
    info = json.loads((out / "meta/info.json").read_text())
    assert info["fps"] == 10 and "next.reward" not in info["features"]
    assert info["features"]["observation.state"]["names"] == [
        "obs/robot0_gripper_qpos[0]",
        "obs/robot0_gripper_qpos[1]",
    ]
    table = _table(out, ["observation.state", "next.success", "episode_index", "index"])
    with h5py.File(src, "r") as f:
        want_state = np.concatenate([f[f"data/demo_{e}/obs/robot0_gripper_qpos"][...] for e in range(3)])
        want_success = np.concatenate([f[f"data/demo_{e}/rewards"][...] != 0 for e in range(3)])
    assert table["observation.state"] == want_state.astype(np.float32).tolist()
    assert table["next.success"] == want_success.tolist()
    tasks = pq.read_table(out / "meta/tasks.parquet").to_pydict()
    assert "lift the cube" in str(tasks)


@pytest.mark.slow  # worker processes start (and import the writer) on a loaded 2-core machine
def test_workers_over_files_write_what_one_process_writes(tmp_path: Path) -> None:
    folder = tmp_path / "libero"
    folder.mkdir()
    for i, lengths in enumerate([(5, 4), (6,), (3, 4)]):
        write_robomimic(folder / f"task_{i}_demo.hdf5", lengths, layout="libero")
    one, two = tmp_path / "one", tmp_path / "two"
    assert run_inproc("convert", str(folder), str(one), "--codec", "h264").returncode == 0
    run = run_inproc("convert", str(folder), str(two), "--codec", "h264", "--workers", "2")
    assert run.returncode == 0, run.stderr
    assert _table(one) == _table(two)
    assert _table(one)["episode_index"] == [e for e, n in enumerate([5, 4, 6, 3, 4]) for _ in range(n)]
