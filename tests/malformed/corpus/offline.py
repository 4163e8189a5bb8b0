"""D4RL flat files, Minari datasets and ManiSkill trajectories damaged: ragged or mis-shaped arrays, NaN, flags of
the wrong shape, metadata missing, unreadable or lying (spaces minari cannot read, unbounded declared shapes,
another storage format, a step count that is not the rows'), a data folder linked out of the dataset, a JPEG row
that does not decode, a trajectory JSON missing or disagreeing with the .h5. Each `convert` is one line naming the
file (and the key), exit 2, nothing under the output."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np

from tests.malformed.corpus.cases import case
from tests.support.malformed import Workspace
from tests.support.offline_sources import write_d4rl, write_maniskill, write_minari


def _convert(id: str, make: Callable[[Workspace], Path], names: str) -> None:
    def build(w: Workspace) -> list[str]:
        return ["convert", str(make(w)), str(w.root / "o"), "--codec", "h264", "--fps", "10"]

    case(id, build, names, ("o",))


def _h5(path: Path, edit: Callable[[h5py.File], None]) -> Path:
    with h5py.File(path, "r+") as f:
        edit(f)
    return path


def _replace(f: h5py.File, key: str, data: np.ndarray) -> None:
    del f[key]
    f.create_dataset(key, data=data)


def _d4rl(w: Workspace, edit: Callable[[h5py.File], None]) -> Path:
    return _h5(write_d4rl(w.path("hopper.hdf5")), edit)


def _nan(f: h5py.File) -> None:
    obs = f["observations"][()]
    obs[5, 1] = np.nan
    _replace(f, "observations", obs)


_convert("d4rl-ragged-observations", lambda w: _d4rl(w, lambda f: _replace(f, "observations", np.zeros((9, 4)))),
         r"hopper\.hdf5: observations: 9 rows, the episode has 11 steps")  # fmt: skip
_convert("d4rl-terminals-not-a-flag", lambda w: _d4rl(w, lambda f: _replace(f, "terminals", np.zeros((11, 2)))),
         r"hopper\.hdf5: terminals: shape \(11, 2\)")  # fmt: skip
_convert("d4rl-nan-in-observations", lambda w: _d4rl(w, _nan),
         r"hopper\.hdf5: episode_1/observations: non-finite value at step 1")  # fmt: skip
_convert("d4rl-actions-of-text", lambda w: _d4rl(w, lambda f: _replace(f, "actions", np.array([b"x"] * 11))),
         r"hopper\.hdf5: actions: ")  # fmt: skip


def _minari(w: Workspace, damage: Callable[[Path], None]) -> Path:
    folder = write_minari(w.root / "datasets", (3, 2))
    damage(folder)
    return folder


def _metadata(edit: Callable[[dict[str, object]], None]) -> Callable[[Path], None]:
    def damage(folder: Path) -> None:
        path = folder / "data" / "metadata.json"
        doc = json.loads(path.read_text())
        edit(doc)
        path.write_text(json.dumps(doc))

    return damage


def _link_out(folder: Path) -> None:
    outside = folder.parent.parent.parent / "elsewhere"
    (folder / "data").rename(outside)
    (folder / "data").symlink_to(outside, target_is_directory=True)


def _bad_jpeg(folder: Path) -> None:
    def edit(f: h5py.File) -> None:
        rows = f["episode_1/observations/cam"]  # Minari's JPEG rows: fixed-length when all are as long, else vlen
        bad = np.full(rows.shape[1] if len(rows.shape) == 2 else 200, 0x5A, np.uint8)
        bad[:3] = (0xFF, 0xD8, 0xFF)  # a JPEG start, then garbage
        rows[1] = bad

    _h5(folder / "data" / "main_data.hdf5", edit)


_MINARI = {
    "no-metadata": (lambda p: (p / "data" / "metadata.json").unlink(), r"data/metadata\.json: missing"),
    "space-not-json": (_metadata(lambda d: d.__setitem__("observation_space", "{not json")),
                       r"metadata\.json\.observation_space: invalid JSON"),
    "space-unknown": (_metadata(lambda d: d.__setitem__("action_space", '{"type": "Graph"}')),
                      r"metadata\.json\.action_space: not a space minari reads"),
    "space-huge": (_metadata(lambda d: d.__setitem__("action_space", json.dumps(
        {"type": "Box", "dtype": "float32", "shape": [100000, 100000, 100], "low": 0, "high": 1}))),
        r"metadata\.json\.action_space: shape \[100000, 100000, 100\]: not a bounded shape"),
    "arrow-format": (_metadata(lambda d: d.__setitem__("data_format", "arrow")),
                     r"metadata\.json: data_format: 'arrow'"),
    "total-steps-lies": (lambda p: _h5(p / "data" / "main_data.hdf5",
                                       lambda f: f["episode_0"].attrs.__setitem__("total_steps", 9)),
                         r"main_data\.hdf5: episode_0/rewards: 3 rows, total_steps says 9"),
    "data-linked-out": (_link_out, r"reach-v0: data: path 'data' leads outside"),
    "bad-jpeg-row": (_bad_jpeg, r"main_data\.hdf5: episode_1/observations/cam: step 1"),
}  # fmt: skip


def _made(
    make: Callable[[Workspace, Callable[[Path], None]], Path], damage: Callable[[Path], None]
) -> Callable[[Workspace], Path]:
    return lambda w: make(w, damage)


for _name, (_damage, _says) in _MINARI.items():
    _convert(f"minari-{_name}", _made(_minari, _damage), _says)


def _maniskill(w: Workspace, damage: Callable[[Path], None]) -> Path:
    path = write_maniskill(w.path("ms/trajectory.h5"), (3, 2), cameras=False)
    damage(path)
    return path


def _json(edit: Callable[[dict[str, object]], None]) -> Callable[[Path], None]:
    def damage(path: Path) -> None:
        meta = path.with_suffix(".json")
        doc = json.loads(meta.read_text())
        edit(doc)
        meta.write_text(json.dumps(doc))

    return damage


def _json_out(path: Path) -> None:
    meta = path.with_suffix(".json")
    outside = path.parent.parent / "elsewhere.json"
    meta.rename(outside)
    meta.symlink_to(outside)


def _episode(key: str, value: object, index: int = 1) -> Callable[[dict[str, object]], None]:
    def edit(doc: dict[str, object]) -> None:
        episodes = doc["episodes"]
        assert isinstance(episodes, list)
        episodes[index][key] = value

    return edit


_MANISKILL = {
    "no-json": (lambda p: p.with_suffix(".json").unlink(), r"trajectory\.json: missing"),
    "json-linked-out": (_json_out, r"trajectory\.h5: its \.json: path 'trajectory\.json' leads outside"),
    "json-not-json": (lambda p: p.with_suffix(".json").write_text("{"), r"trajectory\.json: invalid JSON"),
    "no-env-id": (_json(lambda d: d["env_info"].pop("env_id")), r"trajectory\.json: env_info\.env_id"),  # type: ignore[attr-defined]
    "elapsed-steps-lie": (_json(_episode("elapsed_steps", 7)),
                          r"trajectory\.h5: traj_1/actions: 2 rows, the JSON's elapsed_steps is 7"),
    "control-mode-differs": (_json(_episode("control_mode", "pd_ee_delta_pose")),
                             r"trajectory\.json: episodes\[episode_id=1\]\.control_mode: pd_ee_delta_pose"),
    "episode-not-in-json": (_json(_episode("episode_id", 5)), r"trajectory\.json: episodes: no episode_id 1"),
    "ragged-qpos": (lambda p: _h5(p, lambda f: _replace(f, "traj_1/obs/agent/qpos", np.zeros((7, 9), np.float32))),
                    r"trajectory\.h5: traj_1/obs/agent/qpos: state: not a per-step array: 7 rows"),
}  # fmt: skip
for _name, (_damage, _says) in _MANISKILL.items():
    _convert(f"maniskill-{_name}", _made(_maniskill, _damage), _says)
