"""Class 6 of #49, `quality`'s cache faults: a `.openral/quality.parquet` that is a folder, or a full disk while
the cache is written (ENOSPC at its first write, at its publishing rename), is one line and exit 2 (a traceback
before), and the dataset's own files are untouched."""

from __future__ import annotations

import errno
import shutil
from pathlib import Path

import pytest

from tests.malformed.conftest import corpus_dataset  # noqa: F401  (the session's small recorded dataset)
from tests.support.faults import Faults, inject
from tests.support.inproc import run_inproc
from tests.support.malformed import snapshot


def _data(ds: Path) -> dict[str, bytes | None]:
    """The dataset's own files (the cache under .openral/ aside)."""
    return {k: v for k, v in snapshot(ds).items() if not k.startswith(".openral")}


@pytest.fixture
def ds(tmp_path: Path, corpus_dataset: Path) -> Path:  # noqa: F811
    return Path(shutil.copytree(corpus_dataset, tmp_path / "ds"))


def _one_line(stderr: str, code: int, needle: str) -> None:
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    assert "Traceback" not in stderr and code == 2 and len(lines) == 1, (code, stderr[-2000:])
    assert lines[0].startswith("error: ") and needle in lines[0], lines[0]


def test_a_cache_file_that_is_a_folder_is_one_line(ds: Path) -> None:
    (ds / ".openral/quality.parquet").mkdir(parents=True)
    before = _data(ds)
    done = run_inproc("quality", str(ds))
    _one_line(done.stderr, done.returncode, "quality cache")
    assert _data(ds) == before
    assert (ds / ".openral/quality.parquet").is_dir()


@pytest.mark.parametrize("fail_at", [1, 3])
def test_a_full_disk_while_writing_the_cache_is_one_line(ds: Path, fail_at: int) -> None:
    before = _data(ds)
    with inject(Faults(fail_at=fail_at, errno=errno.ENOSPC, armed=True)) as faults:
        done = run_inproc("quality", str(ds))
    assert faults.failed, faults.calls
    _one_line(done.stderr, done.returncode, "no space left on device while writing the quality cache")
    assert _data(ds) == before
