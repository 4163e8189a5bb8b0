"""A source's splits survive `convert` (#45): an RLDS dataset's `train` and `val` splits (TFDS's
`<name>-<split>.tfrecord-*` shards) and a robomimic file's `mask/train` / `mask/valid` filter keys become the
output's info.json `splits` (lerobot's `"name": "start:end"`), episodes ordered by split so each split is one
range, each episode recording the source split and episode it came from; `--workers` keeps them."""

from __future__ import annotations

import json
from pathlib import Path

import h5py
import numpy as np
import pyarrow.parquet as pq
import pytest

from tests.support.hdf5_layouts import write_robomimic
from tests.support.inproc import run_inproc
from tests.support.rlds_written import write_rlds


def _episodes(out: Path) -> list[dict[str, object]]:
    rows = pq.read_table(out / "meta/episodes").sort_by("episode_index").to_pylist()
    return [{"tasks": r["tasks"], "length": r["length"], **json.loads(r["openral.initial_state"])} for r in rows]


def _splits(out: Path) -> dict[str, str]:
    return json.loads((out / "meta/info.json").read_text())["splits"]  # type: ignore[no-any-return]


def _rlds(tmp: Path) -> Path:
    # written val first: episodes 0-1 are val ("pick up block 0", "... 1"), 2-4 train
    return write_rlds(tmp / "toy_rlds" / "1.0.0", splits={"val": ((2, 3),), "train": ((2,), (3, 2))}, smooth=True)


def _check_rlds(out: Path) -> None:
    assert _splits(out) == {"train": "0:3", "val": "3:5"}
    eps = _episodes(out)
    assert [e["tasks"] for e in eps] == [[f"pick up block {i}"] for i in (2, 3, 4, 0, 1)]
    assert [e["split"] for e in eps] == ["train"] * 3 + ["val"] * 2
    assert [e["source_name"] for e in eps] == ["train/0", "train/1", "train/2", "val/0", "val/1"]


def test_rlds_splits_are_kept(tmp_path: Path) -> None:
    out = tmp_path / "out"
    run = run_inproc("convert", str(_rlds(tmp_path)), str(out), "--fps", "5", "--codec", "h264")
    assert run.returncode == 0, run.stderr
    _check_rlds(out)


@pytest.mark.slow  # worker processes start on a loaded 2-core machine
def test_rlds_splits_are_kept_by_workers(tmp_path: Path) -> None:
    out = tmp_path / "out"
    run = run_inproc("convert", str(_rlds(tmp_path)), str(out), "--fps", "5", "--codec", "h264", "--workers", "2")
    assert run.returncode == 0, run.stderr
    _check_rlds(out)


def test_robomimic_filter_keys_are_splits(tmp_path: Path) -> None:
    src = write_robomimic(tmp_path / "lift.hdf5", lengths=(3, 4, 5))
    with h5py.File(src, "a") as f:
        del f["mask/train"]
        f["mask"].create_dataset("train", data=np.array([b"demo_0", b"demo_2"]))
        f["mask"].create_dataset("valid", data=np.array([b"demo_1"]))
        f["mask"].create_dataset("20_percent", data=np.array([b"demo_1"]))  # a filter key, not a split
    out = tmp_path / "out"
    run = run_inproc("convert", str(src), str(out), "--codec", "h264")
    assert run.returncode == 0, run.stderr
    assert _splits(out) == {"train": "0:2", "valid": "2:3"}
    eps = _episodes(out)
    assert [(e["source_name"], e["split"], e["length"]) for e in eps] == [
        ("demo_0", "train", 3), ("demo_2", "train", 5), ("demo_1", "valid", 4)
    ]  # fmt: skip
    actions = pq.read_table(out / "data").sort_by("index").to_pydict()["action"][3 + 5 :]
    with h5py.File(src, "r") as f:
        assert actions == f["data/demo_1/actions"][...].astype(np.float32).tolist()
