"""What an HDF5 source's data means survives `convert` (#45): a dataset that is not a per-step array of its
episode (robosuite 1.4's `controller_info/*` teleop log: more rows than steps) is listed as ignored by `info`, not
read, and blocks neither `--print-mapping` nor a conversion that does not map it; a mapping that names it is told
why. Success is taken only from a signal that means success: sparse rewards, never robomimic's `dones` (which
may mark the end of every demo); otherwise it is unknown and `--print-mapping` says why. LIBERO's pictures,
stored bottom row first as robosuite renders them, come out upright unless the mapping says `image_origin: top`;
robomimic's (flipped upright by its env wrapper before storing) are kept as stored."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pyarrow.parquet as pq
import yaml

from openral_data.replay.recorded import RecordedDataset
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


def _episode_success(out: Path) -> list[object]:
    table = pq.read_table(out / "meta/episodes").sort_by("episode_index")
    return table.column("openral.success").to_pylist()


def test_success_is_not_guessed_from_dones(tmp_path: Path) -> None:
    src = write_robomimic(tmp_path / "random.hdf5", lengths=(4, 3, 5), sparse=None)  # every demo: dones[-1] = 1
    printed = run_inproc("convert", str(src), "--print-mapping")
    assert printed.returncode == 0, printed.stderr
    assert "# success: not mapped: unknown" in printed.stdout and "dones" in printed.stdout
    assert "success" not in yaml.safe_load(printed.stdout)
    out = tmp_path / "out"
    run = run_inproc("convert", str(src), str(out), "--codec", "h264")
    assert run.returncode == 0, run.stderr
    assert "next.success" not in json.loads((out / "meta/info.json").read_text())["features"]
    assert _episode_success(out) == [None, None, None]


def test_success_from_a_sparse_reward(tmp_path: Path) -> None:
    src = write_robomimic(tmp_path / "lift.hdf5", lengths=(4, 3, 5), sparse=True)  # demo 1: reward 0 throughout
    printed = run_inproc("convert", str(src), "--print-mapping")
    assert yaml.safe_load(printed.stdout)["success"] == {"topic": "rewards"}
    out = tmp_path / "out"
    run = run_inproc("convert", str(src), str(out), "--codec", "h264")
    assert run.returncode == 0, run.stderr
    assert _episode_success(out) == [True, False, True]


def _bright_top(kind: str, path: Path) -> Path:
    """A file whose every picture, seen upright, has bright top rows on a dark rest; stored as `kind` stores it
    (LIBERO: bottom row first)."""
    write_robomimic(path, lengths=(3,), layout=kind)
    key = "obs/agentview_rgb" if kind == "libero" else "obs/agentview_image"
    upright = np.full((3, 64, 64, 3), 30, np.uint8)
    upright[:, :16] = 230
    with h5py.File(path, "a") as f:
        del f[f"data/demo_0/{key}"]
        f.create_dataset(f"data/demo_0/{key}", data=upright[:, ::-1] if kind == "libero" else upright)
    return path


def _top_minus_bottom(out: Path) -> float:
    """Mean brightness of the decoded agentview's top 16 rows minus its bottom 16, over the episode."""
    frames = [f.images["agentview"].astype(np.float64) for f in RecordedDataset(out).frames(0)]
    return float(np.mean([img[:16].mean() - img[-16:].mean() for img in frames]))


def test_libero_pictures_come_out_upright(tmp_path: Path) -> None:
    src = _bright_top("libero", tmp_path / "libero.hdf5")
    printed = run_inproc("convert", str(src), "--print-mapping")
    data = yaml.safe_load(printed.stdout)
    assert data["image_origin"] == "bottom" and "bottom row first" in printed.stdout
    out = tmp_path / "out"
    assert run_inproc("convert", str(src), str(out), "--codec", "h264").returncode == 0
    assert _top_minus_bottom(out) > 150  # the bright rows on top, as the scene is seen
    kept = tmp_path / "kept"
    data["image_origin"] = "top"  # the override: as stored
    mapping = write_yaml(tmp_path / "m.yaml", data)
    run = run_inproc("convert", str(src), str(kept), "--codec", "h264", "--mapping", str(mapping))
    assert run.returncode == 0, run.stderr
    assert _top_minus_bottom(kept) < -150


def test_robomimic_pictures_are_kept_as_stored(tmp_path: Path) -> None:
    src = _bright_top("robomimic", tmp_path / "image.hdf5")
    printed = run_inproc("convert", str(src), "--print-mapping")
    assert yaml.safe_load(printed.stdout)["image_origin"] == "top"
    out = tmp_path / "out"
    assert run_inproc("convert", str(src), str(out), "--codec", "h264").returncode == 0
    assert _top_minus_bottom(out) > 150
