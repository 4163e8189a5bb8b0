"""Class 1 of #49, HDF5 reads outside the source: a file whose dataset is stored in another file (external
storage), an external link, a virtual dataset mapping another file, or an external link to a FIFO is refused in
one line by every command that opens HDF5 (`info`, `convert --print-mapping`, `convert`, `convert --workers`)
before any data is read: the other file's bytes reach no output, and a FIFO never hangs."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np
import pytest

from tests.support.bounded import run_bounded
from tests.support.hdf5_layouts import write_robomimic

CANARY = b"CANARY-7f3a9e-outside-the-source!"  # 33 bytes, a pattern no dataset holds by chance
OBJECT = "data/demo_0/obs/object"  # (4, 10) float64 in write_robomimic


def _source(root: Path) -> Path:
    """The robomimic source, alone in its folder `root/src` (the other files beside that folder)."""
    (root / "src").mkdir()
    return write_robomimic(root / "src" / "src.hdf5", lengths=(4, 3))


def _canary(root: Path) -> Path:
    path = root / "secret.bin"
    path.write_bytes((CANARY * 20)[: 4 * 10 * 8])
    return path


def _other(root: Path) -> Path:
    """Another HDF5 file whose `object` holds the canary's bytes."""
    other = root / "other.hdf5"
    with h5py.File(other, "w") as g:
        g["object"] = np.frombuffer((CANARY * 20)[: 4 * 10 * 8], np.float64).reshape(4, 10)
    return other


def _replaced(root: Path, put: Callable[[h5py.File], object]) -> Path:
    """The source with `OBJECT` deleted and `put` in its place."""
    path = _source(root)
    with h5py.File(path, "r+") as f:
        del f[OBJECT]
        put(f)
    return path


def _external_storage(root: Path) -> Path:
    secret = _canary(root)
    return _replaced(
        root, lambda f: f.create_dataset(OBJECT, shape=(4, 10), dtype="f8", external=[(str(secret), 0, 320)])
    )


def _external_link(root: Path) -> Path:
    other = _other(root)
    return _replaced(root, lambda f: f.__setitem__(OBJECT, h5py.ExternalLink(str(other), "/object")))


def _virtual(root: Path) -> Path:
    layout = h5py.VirtualLayout(shape=(4, 10), dtype="f8")
    layout[...] = h5py.VirtualSource(str(_other(root)), "object", shape=(4, 10))
    return _replaced(root, lambda f: f["data/demo_0/obs"].create_virtual_dataset("object", layout))


def _fifo_link(root: Path) -> Path:
    fifo = root / "pipe.hdf5"
    os.mkfifo(fifo)
    return _replaced(root, lambda f: f.__setitem__(OBJECT, h5py.ExternalLink(str(fifo), "/object")))


MAKERS: dict[str, tuple[Callable[[Path], Path], str]] = {
    "external-storage": (_external_storage, "data/demo_0/obs/object: external storage"),
    "external-link": (_external_link, "data/demo_0/obs/object: an external link"),
    "virtual-dataset": (_virtual, "data/demo_0/obs/object: a virtual dataset"),
    "external-link-to-fifo": (_fifo_link, "data/demo_0/obs/object: an external link"),
}
COMMANDS: dict[str, Callable[[Path, Path], list[str]]] = {
    "info": lambda src, out: ["info", str(src)],
    "print-mapping": lambda src, out: ["convert", str(src), "--print-mapping"],
    "convert": lambda src, out: ["convert", str(src), str(out), "--codec", "h264"],
    "workers": lambda src, out: ["convert", str(src.parent), str(out), "--codec", "h264", "--workers", "2"],
}


def _leaks(out: Path) -> list[str]:
    """Files under `out` (the command's output) holding a piece of the canary."""
    if not out.exists():
        return []
    return [str(p) for p in out.rglob("*") if p.is_file() and CANARY[:16] in p.read_bytes()]


CASES = [
    *(("external-storage", command) for command in COMMANDS),
    ("external-link", "convert"),
    ("virtual-dataset", "convert"),
    ("external-link-to-fifo", "info"),
    ("external-link-to-fifo", "print-mapping"),
]


@pytest.mark.parametrize(("kind", "command"), CASES, ids=[f"{k}-{c}" for k, c in CASES])
def test_hdf5_reading_outside_the_file_is_refused(kind: str, command: str, tmp_path: Path) -> None:
    make, names = MAKERS[kind]
    src = make(tmp_path)
    out = tmp_path / "out"
    run = run_bounded(*COMMANDS[command](src, out), timeout=60)
    assert not run.timed_out, "hung"
    assert "Traceback" not in run.stderr, run.stderr
    lines = [ln for ln in run.stderr.splitlines() if ln.strip()]
    assert run.returncode == 2 and len(lines) == 1, (run.returncode, run.stdout[-500:], run.stderr)
    assert lines[0].startswith(f"error: {src}: {names}"), lines[0]
    assert CANARY[:16].decode() not in run.stdout + run.stderr
    assert not _leaks(out)
    assert not out.exists() or not any(out.rglob("*.parquet"))
