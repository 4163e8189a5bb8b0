"""Class 6 of #29 and the FIFO manifest of class 10: a FIFO where a reader expects a file (info.json, a data or
episodes parquet, openral.json, an mp4, a project manifest) is refused before it is opened for reading, so no
command blocks on it. Each runs in a subprocess killed after 60 s: before the fix every one of them hung."""

from __future__ import annotations

import os
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest

from openral_data.formats.lerobot_v3 import layout
from tests.malformed.conftest import corpus_dataset  # noqa: F401  (the session's small recorded dataset)
from tests.support.bounded import run_bounded


@pytest.fixture
def ds(tmp_path: Path, corpus_dataset: Path) -> Path:  # noqa: F811
    """A fresh copy of the session's small recorded dataset."""
    return Path(shutil.copytree(corpus_dataset, tmp_path / "ds"))


def _first(pattern: str) -> Callable[[Path], Path]:
    return lambda ds: sorted(ds.glob(pattern))[0]


# (command, the file made a FIFO)
CASES: list[tuple[str, Callable[[Path], Path]]] = [
    ("info", lambda ds: ds / layout.INFO_PATH),
    ("stats", _first("data/chunk-*/file-*.parquet")),
    ("stats", _first("meta/episodes/chunk-*/file-*.parquet")),
    ("stats", lambda ds: ds / layout.OPENRAL_PATH),
    ("convert", _first("videos/*/chunk-*/file-*.mp4")),
]


@pytest.mark.parametrize(
    ("command", "which"), CASES, ids=["info-info", "stats-data", "stats-episodes", "stats-openral", "convert-mp4"]
)
def test_a_fifo_in_a_dataset_is_refused(
    command: str,
    which: Callable[[Path], Path],
    tmp_path: Path,
    project: Path,
    ds: Path,
) -> None:
    fifo = which(ds)
    fifo.unlink()
    os.mkfifo(fifo)
    args = (command, str(ds), str(tmp_path / "out")) if command == "convert" else (command, str(ds))
    run = run_bounded(*args)
    assert not run.timed_out, f"{command} blocked on {fifo}"
    lines = [ln for ln in run.stderr.splitlines() if ln.strip()]
    assert run.returncode == 2 and len(lines) == 1, run.stderr
    assert lines[0].startswith(f"error: {fifo}: not a regular file"), lines[0]
    assert not (tmp_path / "out").exists()


def test_a_fifo_manifest_is_listed_as_invalid(project: Path) -> None:
    os.mkfifo(project / "scenes" / "zz_fifo.yaml")
    run = run_bounded("list", "scenes")
    assert not run.timed_out, "list blocked on a FIFO manifest"
    assert run.returncode == 0 and "Traceback" not in run.stderr, run.stderr
    lines = run.stdout.splitlines()
    at = next(i for i, ln in enumerate(lines) if "zz_fifo" in ln)
    assert "invalid" in " ".join(lines[at : at + 2]), run.stdout  # its grid row, or the record's first field


def test_doctor_names_a_fifo_info_json_as_unreadable_not_missing(ds: Path) -> None:
    (ds / layout.INFO_PATH).unlink()
    os.mkfifo(ds / layout.INFO_PATH)
    run = run_bounded("doctor", str(ds))
    assert not run.timed_out and run.returncode == 1, run.stdout + run.stderr
    assert "meta/info.json: cannot read: not a regular file" in run.stdout, run.stdout
    assert "missing" not in run.stdout
