"""The work folders of a parallel run (`record --workers`, `convert --workers`): each worker writes its share as
its own dataset, `worker-NNN/`, under a hidden sibling of the output named after it and this process
(``.OUT.workers-PID``); the shares are merged into OUT (`shards.merge_shards`) and the folder removed, or kept
when a `record --workers` run failed after some episodes were finished."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from openral_data import manifests
from openral_data.formats.jsonfile import load_json
from openral_data.formats.lerobot_v3 import layout


def workers_dir(out: Path) -> Path:
    """Where this process's workers write their shares (one dataset per worker) before the merge into `out`."""
    return out.parent / f".{out.name}.workers-{os.getpid()}"


def worker_dir(workdir: Path, worker: int) -> Path:
    """Worker `worker`'s own dataset in `workdir`."""
    return workdir / f"worker-{worker:03d}"


def fresh_workers_dir(out: Path) -> Path:
    """`workers_dir(out)`, emptied of what a killed run of this process id left (not created)."""
    workdir = workers_dir(out)
    shutil.rmtree(workdir, ignore_errors=True)
    return workdir


def workers_dirs(parent: Path, out_glob: str = "*", pid: int | None = None) -> list[Path]:
    """The work folders in `parent` of the outputs `out_glob` matches: this process's (`pid`) or any's (None)."""
    return sorted(parent.glob(f".{out_glob}.workers-{'*' if pid is None else pid}"))


def find_workers_dir(out: Path | None) -> Path | None:
    """This process's work folder for `out` (None: the default output under datasets/), if it exists."""
    if out is not None:
        return workers_dir(out) if workers_dir(out).is_dir() else None
    found = workers_dirs(manifests.datasets_dir(), pid=os.getpid())
    return found[0] if found else None


def kept_worker_episodes(workdir: Path) -> int:
    """Finished episodes the workers' datasets under `workdir` hold (0 when there are none)."""
    total = 0
    for info in sorted(workdir.glob(f"worker-*/{layout.INFO_PATH}")):
        try:
            total += int(load_json(info)["total_episodes"])
        except (OSError, ValueError, KeyError, TypeError):
            continue
    return total
