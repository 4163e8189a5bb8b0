"""Recovery's quarantine and staged-file sweep never follow a symlink out of the dataset."""

from __future__ import annotations

from pathlib import Path

import pytest

from openral_data.errors import DatasetError
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.recovery import Quarantine, quarantine_staged, staged_files


def test_quarantine_refuses_a_symlinked_state_dir(tmp_path: Path) -> None:
    root, elsewhere = tmp_path / "ds", tmp_path / "elsewhere"
    elsewhere.mkdir()
    (root / "data").mkdir(parents=True)
    staged = root / "data" / ".file-000.parquet.tmp"
    staged.write_bytes(b"staged")
    (root / ".openral").symlink_to(elsewhere, target_is_directory=True)
    q = Quarantine(root)
    with pytest.raises(DatasetError) as err:
        q.keep_copy(staged)
    assert err.value.code == "dataset.unsafe" and not any(elsewhere.iterdir())
    with pytest.raises(DatasetError):
        q.move(staged)
    assert staged.read_bytes() == b"staged" and not any(elsewhere.iterdir())


def test_quarantine_refuses_a_symlinked_quarantine_dir(tmp_path: Path) -> None:
    root, elsewhere = tmp_path / "ds", tmp_path / "elsewhere"
    elsewhere.mkdir()
    (root / ".openral").mkdir(parents=True)
    (root / layout.QUARANTINE_DIR).symlink_to(elsewhere, target_is_directory=True)
    (root / "meta").mkdir()
    info = root / "meta" / "info.json"
    info.write_text("{}")
    with pytest.raises(DatasetError) as err:
        Quarantine(root).keep_copy(info)
    assert err.value.code == "dataset.unsafe" and not any(elsewhere.iterdir())


def test_staged_sweep_does_not_follow_symlinks(tmp_path: Path) -> None:
    root, elsewhere = tmp_path / "ds", tmp_path / "elsewhere"
    (elsewhere / "sub").mkdir(parents=True)
    outside_tmp = elsewhere / "sub" / ".precious.tmp"
    outside_tmp.write_bytes(b"precious")
    (root / "data" / "chunk-000").mkdir(parents=True)
    (root / "data" / "chunk-001").symlink_to(elsewhere / "sub", target_is_directory=True)  # a folder link
    (root / "data" / "chunk-000" / ".linked.tmp").symlink_to(outside_tmp)  # a file link
    real = root / "data" / "chunk-000" / ".file-000.parquet.tmp"
    real.write_bytes(b"staged")
    assert list(staged_files(root)) == [real]
    q = Quarantine(root)
    assert quarantine_staged(root, q) == 1
    assert outside_tmp.read_bytes() == b"precious" and (q.dir / "data" / "chunk-000" / real.name).is_file()
