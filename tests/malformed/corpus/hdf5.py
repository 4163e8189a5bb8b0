"""HDF5 sources of `convert`: truncated and garbage files, an unknown layout, missing keys, ragged episodes, wrong
dtypes, NaN in actions, huge declared shapes, a JPEG row that does not decode, no step rate. Each is one line
naming the file (and the key), exit 2, nothing under the output. A dataset that is not a per-step array refuses
only when the mapping names it (an unmapped one is ignored, not read)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np

from tests.malformed.corpus.cases import case
from tests.support.hdf5_layouts import write_aloha, write_robomimic
from tests.support.malformed import Workspace


def _hdf5_case(id: str, make: Callable[[Workspace], Path], names: str, *extra: str) -> None:
    def build(w: Workspace) -> list[str]:
        return ["convert", str(make(w)), str(w.root / "o"), "--codec", "h264", *extra]

    case(id, build, names, ("o",))


def _robomimic(w: Workspace, edit: Callable[[h5py.File], None]) -> Path:
    path = write_robomimic(w.path("demo.hdf5"), lengths=(4, 3))
    with h5py.File(path, "r+") as f:
        edit(f)
    return path


def _cut(w: Workspace, keep: float) -> Path:
    path = write_robomimic(w.path("full.hdf5"), lengths=(4, 3))
    data = path.read_bytes()
    path.unlink()
    return w.write("cut.hdf5", data[: int(len(data) * keep)])


def _replace(f: h5py.File, key: str, data: np.ndarray) -> None:
    del f[key]
    f.create_dataset(key, data=data)


def _huge(f: h5py.File) -> None:
    """A mapped key (state) whose declared rows are too large to read (an unmapped one is not read at all)."""
    del f["data/demo_1/obs/robot0_eef_pos"]
    f["data/demo_1"].create_dataset("obs/robot0_eef_pos", shape=(3, 100_000, 100_000), dtype="f4", chunks=(1, 1, 1024))


def _bad_jpeg(w: Workspace) -> Path:
    folder = write_aloha(w.path("aloha/x").parent, lengths=(3,), compress=True)
    with h5py.File(folder / "episode_0.hdf5", "r+") as f:
        rows = f["observations/images/top"]
        rows[1] = np.full(rows.shape[1], 0x5A, np.uint8)
        rows[1, :3] = (0xFF, 0xD8, 0xFF)  # a JPEG start, then garbage
    return folder


def _nan(f: h5py.File) -> None:
    actions = f["data/demo_1/actions"][...]
    actions[2, 3] = np.nan
    _replace(f, "data/demo_1/actions", actions)


def _aloha_without_action(w: Workspace) -> Path:
    folder = write_aloha(w.path("aloha/x").parent, lengths=(3, 3))
    with h5py.File(folder / "episode_0.hdf5", "r+") as f:
        del f["action"]
    return folder


_hdf5_case("hdf5-truncated-50", lambda w: _cut(w, 0.5), r"cut\.hdf5")
_hdf5_case("hdf5-truncated-95", lambda w: _cut(w, 0.95), r"cut\.hdf5")
_hdf5_case("hdf5-garbage", lambda w: w.write("g.hdf5", b"\x89HDF\r\n\x1a\n" + b"\x00" * 600), r"g\.hdf5")
_hdf5_case(
    "hdf5-unknown-layout",
    lambda w: _robomimic(w, lambda f: f.move("data", "other")),
    r"demo\.hdf5: /: HDF5 of no known layout",
)
_hdf5_case(
    "hdf5-missing-actions",
    lambda w: _robomimic(w, lambda f: f.__delitem__("data/demo_1/actions")),
    r"demo\.hdf5: data/demo_1/actions: missing",
)
_hdf5_case(
    "hdf5-missing-mapped-key",
    lambda w: _robomimic(w, lambda f: f.__delitem__("data/demo_1/obs/robot0_eef_pos")),
    r"demo\.hdf5: demo_1/obs/robot0_eef_pos: missing",
)
_hdf5_case(
    "hdf5-ragged-episode",
    lambda w: _robomimic(w, lambda f: _replace(f, "data/demo_1/obs/object", np.zeros((5, 10)))),
    r"demo\.hdf5: demo_1/obs/object: environment_state: not a per-step array: 5 rows, the episode has 3 steps",
)
_hdf5_case(
    "hdf5-num-samples-disagrees",
    lambda w: _robomimic(w, lambda f: f["data/demo_0"].attrs.__setitem__("num_samples", 9)),
    r"demo\.hdf5: data/demo_0: num_samples",
)
_hdf5_case(
    "hdf5-wrong-dtype",
    lambda w: _robomimic(w, lambda f: _replace(f, "data/demo_1/rewards", np.array([b"a", b"b", b"c"]))),
    r"demo\.hdf5: demo_1/rewards: reward: not a per-step array",
)
_hdf5_case(
    "hdf5-compound-dtype",
    lambda w: _robomimic(
        w, lambda f: _replace(f, "data/demo_1/actions", np.zeros(3, dtype=[("a", "f4"), ("b", "i4")]))
    ),
    r"demo\.hdf5: demo_1/actions: action: not a per-step array: dtype",
)
_hdf5_case(
    "hdf5-nan-in-actions", lambda w: _robomimic(w, _nan), r"demo\.hdf5: demo_1/actions: non-finite value at step 2"
)
_hdf5_case(
    "hdf5-huge-declared-shape",
    lambda w: _robomimic(w, _huge),
    r"demo\.hdf5: demo_1/obs/robot0_eef_pos: state: not a per-step array: declared shape",
)
_hdf5_case(
    "hdf5-bad-env-args",
    lambda w: _robomimic(w, lambda f: f["data"].attrs.__setitem__("env_args", "{not json")),
    r"demo\.hdf5: data/attrs\.env_args",
)
_hdf5_case(
    "hdf5-bad-ep-meta",
    lambda w: _robomimic(w, lambda f: f["data/demo_1"].attrs.__setitem__("ep_meta", "{not json")),
    r"demo\.hdf5: data/demo_1/attrs\.ep_meta",
)
_hdf5_case("hdf5-aloha-bad-jpeg-row", _bad_jpeg, r"episode_0\.hdf5: observations/images/top: step 1", "--fps", "50")
_hdf5_case("hdf5-aloha-no-fps", lambda w: write_aloha(w.path("aloha/x").parent, lengths=(3,)), r"aloha: fps")
_hdf5_case("hdf5-aloha-missing-action", _aloha_without_action, r"episode_0\.hdf5: action: missing", "--fps", "50")


def _outside(w: Workspace, how: str) -> Path:
    """The source's `data/demo_0/obs/object` read from another file: external storage, an external link or a
    virtual dataset (#49: refused before any data is read)."""
    other = w.path("elsewhere/other.hdf5")
    with h5py.File(other, "w") as g:
        g["object"] = np.zeros((4, 10))
    w.write("elsewhere/raw.bin", b"\x00" * 320)
    path = write_robomimic(w.path("src/demo.hdf5"), lengths=(4, 3))
    with h5py.File(path, "r+") as f:
        del f["data/demo_0/obs/object"]
        if how == "storage":
            f.create_dataset("data/demo_0/obs/object", shape=(4, 10), dtype="f8",
                             external=[(str(w.root / "elsewhere/raw.bin"), 0, 320)])  # fmt: skip
        elif how == "link":
            f["data/demo_0/obs/object"] = h5py.ExternalLink(str(other), "/object")
        else:
            layout = h5py.VirtualLayout(shape=(4, 10), dtype="f8")
            layout[...] = h5py.VirtualSource(str(other), "object", shape=(4, 10))
            f["data/demo_0/obs"].create_virtual_dataset("object", layout)
    return path


_hdf5_case("hdf5-external-storage", lambda w: _outside(w, "storage"), r"demo\.hdf5: data/demo_0/obs/object: external")
_hdf5_case("hdf5-external-link", lambda w: _outside(w, "link"), r"demo\.hdf5: data/demo_0/obs/object: an external link")
_hdf5_case("hdf5-virtual-dataset", lambda w: _outside(w, "vds"), r"demo\.hdf5: data/demo_0/obs/object: a virtual")
