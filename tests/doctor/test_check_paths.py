"""doctor's path checks: unsafe control files, journals, keys, indices and templates are error findings with
stable codes, never "repairable", and never make `check` follow them, block or raise."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from openral_data.doctor import check
from openral_data.formats.lerobot_v3 import layout
from tests.support.cli import run_cli
from tests.support.recorded import record_mock_cli

EPISODES = "meta/episodes/chunk-000/file-000.parquet"


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return record_mock_cli(tmp_path_factory.mktemp("check_paths"), [3, 4])


@pytest.fixture
def ds(recorded: Path, tmp_path: Path) -> Path:
    root = tmp_path / "ds"
    shutil.copytree(recorded, root, symlinks=True)
    return root


def _codes(root: Path) -> dict[str, bool]:
    return {f.code: f.repairable for f in check(root) if f.severity == "error"}


def test_healthy_recording_has_no_path_findings(ds: Path) -> None:
    assert check(ds) == []


def test_symlinked_control_files(ds: Path, tmp_path: Path) -> None:
    target = tmp_path / "target"
    target.write_text("{}")
    (ds / layout.LOCK_PATH).symlink_to(target)
    (ds / layout.RECORD_PATH).unlink()
    (ds / layout.RECORD_PATH).symlink_to(target)
    found = [f for f in check(ds) if f.code == "control.unsafe"]
    assert sorted(f.where for f in found) == [layout.LOCK_PATH, layout.RECORD_PATH]
    assert not any(f.repairable for f in found) and target.read_text() == "{}"


def test_safe_journal_is_repairable_unsafe_is_not(ds: Path) -> None:
    journal = ds / layout.JOURNAL_PATH
    journal.write_text(json.dumps({"renames": [["../meta/.info.json.tmp", "../meta/info.json"]]}))
    assert _codes(ds).get("writer.journal") is True
    journal.write_text(json.dumps({"renames": [["../../x/.y.tmp", "../../x/y"]]}))
    codes = _codes(ds)
    assert codes.get("journal.unsafe") is False and "writer.journal" not in codes
    journal.write_text("{")
    assert _codes(ds).get("journal.invalid") is False


@pytest.mark.parametrize("value", [-1, 10**7])
def test_out_of_range_file_index_is_a_finding_not_a_crash(ds: Path, value: int) -> None:
    path = ds / EPISODES
    t = pq.read_table(path)
    col = "videos/observation.images.front/file_index"
    i = t.column_names.index(col)
    t = t.set_column(i, col, pa.array([value] * t.num_rows, pa.int64()))
    pq.write_table(t, path)
    assert "episodes.file_index" in _codes(ds)


def test_fifo_lock_does_not_block(ds: Path) -> None:
    os.mkfifo(ds / layout.LOCK_PATH)
    assert _codes(ds) == {"control.unsafe": False}


def test_nonstandard_template_is_an_error(ds: Path) -> None:
    info = json.loads((ds / layout.INFO_PATH).read_text())
    info["data_path"] = "data/{chunk_index}/{file_index}.parquet"
    (ds / layout.INFO_PATH).write_text(json.dumps(info))
    assert "info.template" in _codes(ds)


@pytest.mark.parametrize(
    ("rel", "code"),
    [
        ("data/chunk-000/file-000.parquet", "data.unreadable"),
        (EPISODES, "episodes.unreadable"),
        ("videos/observation.images.front/chunk-000/file-000.mp4", "video.missing"),  # not a regular file
    ],
)
def test_a_fifo_in_place_of_a_dataset_file_is_a_finding_not_a_hang(ds: Path, rel: str, code: str) -> None:
    """pyarrow and FFmpeg open files by name and would wait on a FIFO for ever; doctor reports it instead."""
    (ds / rel).unlink()
    os.mkfifo(ds / rel)
    done = run_cli("doctor", str(ds), "--deep", timeout=60)
    assert done.returncode == 1, done.stderr
    assert "Traceback" not in done.stderr
    assert code in _codes(ds)
