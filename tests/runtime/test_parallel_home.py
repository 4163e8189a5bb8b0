"""Parallel runs have one home, runtime/parallel: the one-process-or-N choice every `--workers` command makes,
and the work folders beside the output, which `record --workers`, `convert --workers`, Ctrl-C's report and a
pipeline's clean-up of a killed item all name the same way."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from openral_data.runtime.parallel.choice import is_parallel
from openral_data.runtime.parallel.workdir import (
    find_workers_dir,
    fresh_workers_dir,
    kept_worker_episodes,
    worker_dir,
    workers_dir,
    workers_dirs,
)


@pytest.mark.parametrize(
    ("workers", "executor", "parallel"),
    [
        (1, "local", False),  # this process
        (2, "local", True),
        (1, "ray", True),  # one Ray task is still a worker
        (4, "ray", True),
        (0, "local", True),  # not this process: the parallel run refuses it in one line
    ],
)
def test_one_process_or_n(workers: int, executor: str, parallel: bool) -> None:
    assert is_parallel(workers, executor) is parallel


def _share(workdir: Path, worker: int, episodes: object) -> None:
    meta = worker_dir(workdir, worker) / "meta"
    meta.mkdir(parents=True)
    (meta / "info.json").write_text(json.dumps({"total_episodes": episodes}))


def test_work_folders_are_named_once(tmp_path: Path) -> None:
    out = tmp_path / ".rec.partial-ab12"  # a pipeline item's output while it is written
    workdir = workers_dir(out)
    assert workdir == tmp_path / f"..rec.partial-ab12.workers-{os.getpid()}"  # hidden, beside the output
    assert find_workers_dir(out) is None
    _share(workdir, 0, 3)
    _share(workdir, 1, 2)
    _share(workdir, 2, "two")  # a share whose info cannot be read counts nothing
    assert sorted(p.name for p in workdir.iterdir()) == ["worker-000", "worker-001", "worker-002"]
    assert find_workers_dir(out) == workdir
    assert kept_worker_episodes(workdir) == 5
    other = tmp_path / "..rec.partial-cd34.workers-1"  # another (killed) process's
    other.mkdir()
    assert workers_dirs(tmp_path, ".rec.partial-*") == [workdir, other]  # what a pipeline cleans up
    assert workers_dirs(tmp_path, pid=os.getpid()) == [workdir]
    assert fresh_workers_dir(out) == workdir and not workdir.exists()
