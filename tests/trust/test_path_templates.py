"""Class 5 of #49, path templates only in the forms lerobot writes: an info.json `data_path` or `video_path`
whose field has a width of 300 (a `File name too long` traceback before) or of 999999999 (gigabytes allocated
before) is one line in `info`, `stats`, `tasks list` and the edits, before anything is formatted."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from tests.malformed.conftest import corpus_dataset  # noqa: F401  (the session's small recorded dataset)
from tests.support.bounded import run_bounded
from tests.support.inproc import run_inproc

BAD = {
    "width-300": ("data_path", "data/chunk-{chunk_index:03d}/file-{file_index:0300d}.parquet"),
    "width-1e9": ("data_path", "data/chunk-{chunk_index:03d}/file-{file_index:0999999999d}.parquet"),
    "video-width-300": ("video_path", "videos/{video_key}/chunk-{chunk_index:0300d}/file-{file_index:03d}.mp4"),
    "attribute": ("data_path", "data/chunk-{chunk_index.__class__}/file-{file_index:03d}.parquet"),
}
COMMANDS = {
    "info": lambda ds, out: ["info", str(ds)],
    "stats": lambda ds, out: ["stats", str(ds)],
    "tasks-list": lambda ds, out: ["tasks", "list", str(ds)],
    "episodes-delete": lambda ds, out: ["episodes", "delete", str(ds), "--episodes", "0", "--out", str(out)],
}


def _dataset(src: Path, dst: Path, field: str, template: str) -> Path:
    shutil.copytree(src, dst)
    info = dst / "meta/info.json"
    info.write_text(json.dumps({**json.loads(info.read_text()), field: template}))
    return dst


@pytest.mark.parametrize("bad", list(BAD))
@pytest.mark.parametrize("command", list(COMMANDS))
def test_a_path_template_beyond_lerobots_forms_is_one_line(
    bad: str,
    command: str,
    corpus_dataset: Path,  # noqa: F811
    tmp_path: Path,
) -> None:
    field, template = BAD[bad]
    ds = _dataset(corpus_dataset, tmp_path / "ds", field, template)
    out = tmp_path / "out"
    run = run_bounded(*COMMANDS[command](ds, out), timeout=60) if bad == "width-1e9" else None
    if run is None:
        done = run_inproc(*COMMANDS[command](ds, out))
        code, stderr = done.returncode, done.stderr
    else:
        assert not run.timed_out, "hung"
        code, stderr = run.returncode, run.stderr
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    assert "Traceback" not in stderr and "MemoryError" not in stderr, stderr[-2000:]
    assert code == 2 and len(lines) == 1, (code, stderr[-2000:])
    assert lines[0].startswith(f"error: {ds / 'meta/info.json'}: {field}: "), lines[0]
    assert "is not a field lerobot writes" in lines[0], lines[0]
    assert not out.exists()
