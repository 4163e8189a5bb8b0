"""Atomic replacement and staged batches: a reader never sees a half-written file."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import pytest

from openral_data.formats import atomic


def _writes(text: str) -> Callable[[Path], None]:
    def write(path: Path) -> None:
        path.write_text(text)

    return write


def test_write_with_replaces_and_leaves_no_temp(tmp_path: Path) -> None:
    target = tmp_path / "a" / "info.json"
    atomic.write_with(target, _writes("one"))
    atomic.write_with(target, _writes("two"))
    assert target.read_text() == "two" and sorted(p.name for p in target.parent.iterdir()) == ["info.json"]


def test_failed_writer_keeps_the_old_file(tmp_path: Path) -> None:
    target = tmp_path / "info.json"
    target.write_text("old")

    def boom(path: Path) -> None:
        path.write_text("half")
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        atomic.write_with(target, boom)
    assert target.read_text() == "old" and [p.name for p in tmp_path.iterdir()] == ["info.json"]


def test_batch_lands_nothing_until_commit(tmp_path: Path) -> None:
    batch = atomic.Batch()
    batch.write_with(tmp_path / "data.parquet", _writes("d"))
    batch.write_with(tmp_path / "meta" / "info.json", _writes("i"))
    assert not (tmp_path / "data.parquet").exists() and not (tmp_path / "meta" / "info.json").exists()
    with pytest.raises(ValueError, match="already staged"):
        batch.write_with(tmp_path / "data.parquet", _writes("again"))
    batch.commit()
    assert (tmp_path / "data.parquet").read_text() == "d" and (tmp_path / "meta" / "info.json").read_text() == "i"
    assert not list(tmp_path.rglob("*.tmp"))


def test_batch_discard_removes_staged_files(tmp_path: Path) -> None:
    (tmp_path / "info.json").write_text("committed")
    batch = atomic.Batch()
    batch.write_with(tmp_path / "info.json", _writes("staged"))
    batch.discard()
    assert (tmp_path / "info.json").read_text() == "committed" and not list(tmp_path.rglob("*.tmp"))


def test_journal_replays_an_interrupted_commit(tmp_path: Path) -> None:
    journal = tmp_path / ".openral" / "journal.json"
    (tmp_path / "info.json").write_text("old")
    batch = atomic.Batch(journal=journal)
    batch.write_with(tmp_path / "data.parquet", _writes("d"))
    batch.write_with(tmp_path / "info.json", _writes("new"))
    assert batch.write_journal()
    os.replace(tmp_path / ".data.parquet.tmp", tmp_path / "data.parquet")  # killed after the first rename
    assert (tmp_path / "info.json").read_text() == "old"
    assert atomic.replay_journal(journal) == 1
    assert (tmp_path / "info.json").read_text() == "new" and (tmp_path / "data.parquet").read_text() == "d"
    assert not journal.exists() and not list(tmp_path.rglob("*.tmp"))
    assert atomic.replay_journal(journal) == 0


def test_committed_journal_batch_leaves_no_journal(tmp_path: Path) -> None:
    journal = tmp_path / "journal.json"
    batch = atomic.Batch(journal=journal)
    batch.write_with(tmp_path / "a", _writes("a"))
    batch.commit()
    assert (tmp_path / "a").read_text() == "a" and not journal.exists()
