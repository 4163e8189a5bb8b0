"""Class 4 and 6 of #49 for v2.x metadata: `upgrade` refuses a `meta/` symlink leading out of OLD (it read the
outside folder's info.json and episodes before), and a JSON Lines file is bounded in lines (each row a dict in
memory: a 60 MB episodes.jsonl of 20 M lines took 3.4 GB) and in line size, before a line is parsed."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from openral_data.errors import DatasetError
from openral_data.formats.lerobot_v2._jsonl import MAX_JSONL_LINES, read_jsonl
from tests.support.inproc import run_inproc
from tests.support.legacy_v2 import write_v2


def test_upgrade_refuses_a_meta_symlink_out_of_old(tmp_path: Path) -> None:
    outside = write_v2(tmp_path / "outside", lengths=(3,), video=False)
    old = tmp_path / "old"
    shutil.copytree(outside, old)
    shutil.rmtree(old / "meta")
    (old / "meta").symlink_to(outside / "meta")
    new = tmp_path / "new"
    done = run_inproc("upgrade", str(old), str(new))
    lines = [ln for ln in done.stderr.splitlines() if ln.strip()]
    assert done.returncode == 2 and len(lines) == 1 and "Traceback" not in done.stderr, done.stderr[-2000:]
    assert lines[0].startswith(f"error: {old / 'meta/info.json'}: ") and "leads outside" in lines[0], lines[0]
    assert not new.exists()


def test_a_jsonl_file_is_bounded_in_lines_before_parsing(tmp_path: Path) -> None:
    path = tmp_path / "episodes.jsonl"
    path.write_bytes(b"{}\n" * (MAX_JSONL_LINES + 1))
    with pytest.raises(DatasetError, match=rf"^{path}: more than {MAX_JSONL_LINES} lines"):
        read_jsonl(path)
    path.write_bytes(b'{"a": 1}\n' * 3)
    assert read_jsonl(path) == [{"a": 1}] * 3


def test_a_jsonl_line_is_bounded(tmp_path: Path) -> None:
    path = tmp_path / "tasks.jsonl"
    path.write_bytes(b'{"task_index": 0, "task": "' + b"x" * (17 << 20) + b'"}\n')
    with pytest.raises(DatasetError, match=rf"^{path}: line 1: over"):
        read_jsonl(path)
