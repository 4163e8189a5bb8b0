"""`convert SRC DST` with no mapping on each HDF5 layout (robomimic, LIBERO, MimicGen, ALOHA raw and compressed):
the converted values equal the source read by h5py directly (numbers exactly, pictures within video codec
tolerance of the stored pixels, or of an independent PIL decode of ALOHA's JPEG rows), lerobot 0.6.1 loads the
output frame-exact against our own decode, and `doctor --deep` finds it healthy."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import pyarrow.parquet as pq
import pytest

from openral_data.replay.recorded import RecordedDataset
from tests.support.array_sources import lerobot_matches_ours
from tests.support.hdf5_layouts import decode_jpeg_row, write_aloha, write_robomimic
from tests.support.inproc import run_inproc

VIDEO_TOL = 6.0  # mean absolute pixel difference after h264 at 64x64 (smooth gradients)


def _source(kind: str, tmp: Path) -> tuple[Path, list[str]]:
    if kind.startswith("aloha"):
        return write_aloha(tmp / "sim_transfer_cube", compress=kind == "aloha-compressed"), ["--fps", "50"]
    return write_robomimic(tmp / f"{kind}.hdf5", layout=kind), []


def _expected(kind: str, src: Path) -> list[dict[str, Any]]:
    """Per episode, read with h5py: state, action, env, reward, success, pictures (camera -> frames), task."""
    out = []
    if kind.startswith("aloha"):
        for file in sorted(src.glob("episode_*.hdf5")):
            with h5py.File(file, "r") as f:
                cams = {}
                for cam in ("angle", "top"):
                    rows = f[f"observations/images/{cam}"][...]
                    cams[cam] = np.stack([decode_jpeg_row(r) for r in rows]) if rows.ndim == 2 else rows
                out.append({"state": f["observations/qpos"][...], "action": f["action"][...], "env": None,
                            "reward": None, "success": None, "cams": cams, "task": src.name})  # fmt: skip
        return out
    state_keys = (
        ["ee_pos", "gripper_states", "joint_states"] if kind == "libero" else ["robot0_eef_pos", "robot0_gripper_qpos"]
    )
    cam_keys = (
        {"agentview": "agentview_rgb", "eye_in_hand": "eye_in_hand_rgb"}
        if kind == "libero"
        else {"agentview": "agentview_image"}
    )
    with h5py.File(src, "r") as f:
        task = json.loads(f["data"].attrs["problem_info"])["language_instruction"] if kind == "libero" else "Lift"
        for e in range(len(f["data"])):
            d = f[f"data/demo_{e}"]
            out.append({
                "state": np.concatenate([d[f"obs/{k}"][...] for k in state_keys], axis=1),
                "action": d["actions"][...],
                "env": None if kind == "libero" else d["obs/object"][...],
                "reward": d["rewards"][...],
                # sparse reward (robomimic, MimicGen): success where it is non-zero; LIBERO says nothing: unknown
                "success": None if kind == "libero" else d["rewards"][...] != 0,
                # LIBERO stores robosuite's renders bottom row first: converted upright
                "cams": {name: _upright(kind, d[f"obs/{k}"][...]) for name, k in cam_keys.items()},
                "task": task,
            })  # fmt: skip
    return out


def _upright(kind: str, pictures: np.ndarray[Any, Any]) -> np.ndarray[Any, Any]:
    return pictures[:, ::-1] if kind == "libero" else pictures


def _f32(a: np.ndarray[Any, Any]) -> list[Any]:
    return np.asarray(a, np.float32).tolist()  # type: ignore[no-any-return]


@pytest.mark.parametrize("kind", ["robomimic", "libero", "mimicgen", "aloha", "aloha-compressed"])
def test_hdf5_layout_converts_with_no_mapping(tmp_path: Path, kind: str) -> None:
    src, extra = _source(kind, tmp_path)
    out = tmp_path / "out"
    run = run_inproc("convert", str(src), str(out), "--codec", "h264", *extra)
    assert run.returncode == 0, run.stderr
    want = _expected(kind, src)
    table = pq.read_table(out / "data").sort_by("index")
    eps = table.column("episode_index").to_pylist()
    assert sorted(set(eps)) == list(range(len(want)))
    ours = RecordedDataset(out)
    for e, w in enumerate(want):
        rows = table.filter(np.array(eps) == e)
        assert rows.column("observation.state").to_pylist() == _f32(w["state"])
        assert rows.column("action").to_pylist() == _f32(w["action"])
        if w["env"] is not None:
            assert rows.column("observation.environment_state").to_pylist() == _f32(w["env"])
        if w["reward"] is not None:
            assert rows.column("next.reward").to_pylist() == _f32(w["reward"])
        if w["success"] is not None:
            assert rows.column("next.success").to_pylist() == w["success"].tolist()
        else:
            assert "next.success" not in table.column_names
        frames = list(ours.frames(e))
        assert {f.task for f in frames} == {w["task"]}
        for name, pictures in w["cams"].items():
            got = np.stack([f.images[name] for f in frames]).astype(np.float64)
            assert np.abs(got - pictures).mean() <= VIDEO_TOL, (name, np.abs(got - pictures).mean())
    lerobot_matches_ours(out, ours)
    doctor = run_inproc("doctor", str(out), "--deep")
    assert doctor.returncode == 0 and "healthy" in doctor.stdout, doctor.stdout + doctor.stderr
