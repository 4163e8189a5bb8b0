"""`convert SRC DST` of a zarr replay buffer (diffusion policy / UMI) through the array-source path: the values
equal zarr's own read of the store (numbers exactly, pictures within video codec tolerance of the stored raw
pixels), lerobot 0.6.1 loads the output frame-exact against our decode, `doctor --deep` finds it healthy; the
store declares no frame rate, so a missing `--fps` is one line, exit 2, nothing written; `--print-mapping` gives
the default mapping (diffusion policy's `data/state` / `data/agent_pos`, UMI's robot0_* vectors)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import pytest
import zarr

from openral_data.replay.recorded import RecordedDataset
from tests.cli.test_json import parse
from tests.support.array_sources import converted_episodes, lerobot_matches_ours
from tests.support.hdf5_layouts import picture, vector
from tests.support.inproc import run_inproc
from tests.support.replay_buffer import write_replay_buffer

VIDEO_TOL = 6.0  # mean absolute pixel difference after h264 at 64x64 (smooth gradients)


def _episodes(lengths: tuple[int, ...], state_key: str = "state") -> list[dict[str, np.ndarray[Any, Any]]]:
    return [
        {
            "img": np.stack([picture(e, t) for t in range(n)]),
            state_key: np.stack([vector(e, t, 5, 0.5) for t in range(n)]).astype(np.float32),
            "action": np.stack([vector(e, t, 2, -1.0) for t in range(n)]).astype(np.float32),
            "n_contacts": np.arange(n, dtype=np.int64) % 3,
        }
        for e, n in enumerate(lengths)
    ]


@pytest.fixture(scope="module")
def store(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_replay_buffer(tmp_path_factory.mktemp("zarr") / "pusht.zarr", _episodes((6, 4, 7)))


def _zarr_episodes(path: Path) -> list[dict[str, np.ndarray[Any, Any]]]:
    """Each episode's rows as zarr itself reads them (meta/episode_ends cut the concatenated data arrays)."""
    root: Any = zarr.open_group(str(path), mode="r")
    ends = [int(e) for e in root["meta/episode_ends"][:]]
    data = {k: np.asarray(a[:]) for k, a in root["data"].arrays()}
    return [{k: v[s:e] for k, v in data.items()} for s, e in zip([0, *ends[:-1]], ends, strict=True)]


def test_zarr_store_converts_with_the_default_mapping(store: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    want = _zarr_episodes(store)
    tables = converted_episodes(store, out, len(want), "--fps", "10")
    assert json.loads((out / "meta" / "info.json").read_text())["fps"] == 10
    ours = RecordedDataset(out)
    for e, (w, rows) in enumerate(zip(want, tables, strict=True)):
        assert rows.column("observation.state").to_pylist() == w["state"].tolist()
        assert rows.column("action").to_pylist() == w["action"].tolist()
        frames = list(ours.frames(e))
        assert {f.task for f in frames} == {"pusht"}
        got = np.stack([f.images["img"] for f in frames]).astype(np.float64)
        assert np.abs(got - w["img"]).mean() <= VIDEO_TOL
    lerobot_matches_ours(out, ours)
    doctor = run_inproc("doctor", str(out), "--deep")
    assert doctor.returncode == 0 and "healthy" in doctor.stdout, doctor.stdout + doctor.stderr


def test_zarr_store_without_fps_is_one_line_and_writes_nothing(store: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    run = run_inproc("convert", str(store), str(out))
    assert run.returncode == 2 and run.stderr.count("\n") == 1, run.stderr
    assert run.stderr.startswith(f"error: {store}: fps: ") and "--fps" in run.stderr
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == []


def test_zarr_print_mapping_and_workers(store: Path, tmp_path: Path) -> None:
    run = run_inproc("convert", str(store), "--print-mapping", "--json")
    assert run.returncode == 0, run.stderr
    doc = parse(run.stdout, "convert print-mapping")
    assert doc["layout"] == "zarr" and doc["mapping"]["cameras"] == {"img": "data/img"}
    assert doc["mapping"]["state"]["topic"] == "data/state" and doc["mapping"]["action"]["topic"] == "data/action"
    assert "fps" in doc["guesses"]
    one, two = tmp_path / "one", tmp_path / "two"
    assert run_inproc("convert", str(store), str(one), "--fps", "10", "--codec", "h264").returncode == 0
    run = run_inproc("convert", str(store), str(two), "--fps", "10", "--codec", "h264", "--workers", "2")
    assert run.returncode == 0, run.stderr  # a single store is one block
    for column in ("episode_index", "frame_index", "observation.state", "action"):
        assert pq.read_table(two / "data").column(column) == pq.read_table(one / "data").column(column)


def test_umi_like_store_maps_its_vectors_as_state(tmp_path: Path) -> None:
    """No data/state: every float vector but the action (UMI's robot0_eef_pos, ...) is the state, in key order."""
    episodes = _episodes((3, 2), state_key="robot0_eef_pos")
    for ep in episodes:
        ep["robot0_gripper_width"] = ep["robot0_eef_pos"][:, :1] * 2
    path = write_replay_buffer(tmp_path / "dataset.zarr", episodes)
    run = run_inproc("convert", str(path), "--print-mapping", "--json")
    assert run.returncode == 0, run.stderr
    doc = json.loads(run.stdout)
    parts = [p["topic"] for p in doc["mapping"]["state"]["parts"]]
    assert parts == ["data/robot0_eef_pos", "data/robot0_gripper_width"] and "state" in doc["guesses"]
    assert doc["mapping"]["task"] == "dataset"


def test_info_and_convert_share_one_detector_list(store: Path, tmp_path: Path) -> None:
    """`info SRC --json` recognises every layout `convert` does (HDF5 too), from the one source registry."""
    from openral_data.convert.kinds import detect
    from tests.support.hdf5_layouts import write_robomimic
    from tests.support.rlds_written import write_rlds

    sources = {
        "robomimic": write_robomimic(tmp_path / "lift.hdf5"),
        "zarr": store,
        "rlds": write_rlds(tmp_path / "toy_rlds" / "1.0.0"),
    }
    for layout, path in sources.items():
        found = detect(path)
        assert found is not None and found.handle.layout == layout
        found.handle.close()
        run = run_inproc("info", str(path), "--json")
        assert run.returncode == 0 and json.loads(run.stdout)["layout"] == layout, run.stderr
