"""Atomic replacement and staged batches: a reader never sees a half-written file."""

from __future__ import annotations

import errno
import json
import os
import threading
from collections.abc import Callable
from pathlib import Path

import pytest

from openral_data.errors import DatasetError
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
    info, data = tmp_path / "meta" / "info.json", tmp_path / "data" / "data.parquet"
    info.parent.mkdir()
    info.write_text("old")
    batch = atomic.Batch(journal=journal)
    batch.write_with(data, _writes("d"))
    batch.write_with(info, _writes("new"))
    assert batch.write_journal()
    os.replace(atomic.tmp_name(data), data)  # killed after the first rename
    assert info.read_text() == "old"
    assert atomic.replay_journal(journal) == 1
    assert info.read_text() == "new" and data.read_text() == "d"
    assert not journal.exists() and not list(tmp_path.rglob("*.tmp"))
    assert atomic.replay_journal(journal) == 0


def test_committed_journal_batch_leaves_no_journal(tmp_path: Path) -> None:
    journal = tmp_path / ".openral" / "journal.json"
    batch = atomic.Batch(journal=journal)
    batch.write_with(tmp_path / "meta" / "a", _writes("a"))
    batch.commit()
    assert (tmp_path / "meta" / "a").read_text() == "a" and not journal.exists()


def _crafted(root: Path, renames: object) -> Path:
    journal = root / ".openral" / "journal.json"
    journal.parent.mkdir(parents=True, exist_ok=True)
    journal.write_text(json.dumps({"renames": renames}))
    return journal


@pytest.mark.parametrize(
    "renames",
    [
        pytest.param([["../../outside/canary.txt", "../../outside/moved.txt"]], id="both-outside"),
        pytest.param([["../data/.f.tmp", "../data/f"], ["../../outside/canary.txt", "../meta/x"]], id="late-entry"),
        pytest.param([["../meta/.x.tmp", "/abs/x"]], id="absolute"),
        pytest.param([["../.x.tmp", "../x"]], id="root-level"),
        pytest.param([["../data/other.tmp", "../data/f"]], id="not-its-staged-file"),
        pytest.param([["../data/.f.tmp", "../data/link/f"]], id="through-symlink"),
    ],
)
def test_crafted_journal_is_refused_before_any_rename(tmp_path: Path, renames: object) -> None:
    root, outside = tmp_path / "ds", tmp_path / "outside"
    outside.mkdir()
    canary = outside / "canary.txt"
    canary.write_bytes(b"canary\x00bytes")
    (root / "data").mkdir(parents=True)
    (root / "meta").mkdir()
    (root / "data" / ".f.tmp").write_text("staged")
    (root / "data" / "link").symlink_to(outside)
    journal = _crafted(root, renames)
    with pytest.raises(DatasetError) as err:
        atomic.replay_journal(journal)
    assert err.value.code == "dataset.unsafe"
    assert canary.read_bytes() == b"canary\x00bytes" and sorted(p.name for p in outside.iterdir()) == ["canary.txt"]
    assert (root / "data" / ".f.tmp").read_text() == "staged" and not (root / "data" / "f").exists()
    assert journal.exists()  # left for a person to look at


@pytest.mark.parametrize("body", ['{"renames": [["a"]]}', "[1]", '{"renames": "x"}', "not json", ""])
def test_garbage_journal_is_one_line(tmp_path: Path, body: str) -> None:
    journal = tmp_path / ".openral" / "journal.json"
    journal.parent.mkdir()
    journal.write_text(body)
    with pytest.raises(DatasetError) as err:
        atomic.replay_journal(journal)
    assert err.value.code == "dataset.invalid" and "\n" not in str(err.value)


def test_symlinked_or_fifo_journal_is_refused(tmp_path: Path) -> None:
    outside = tmp_path / "outside.json"
    outside.write_text(json.dumps({"renames": []}))
    journal = tmp_path / "ds" / ".openral" / "journal.json"
    journal.parent.mkdir(parents=True)
    journal.symlink_to(outside)
    with pytest.raises(DatasetError) as err:
        atomic.replay_journal(journal)
    assert err.value.code == "dataset.unsafe" and outside.exists()
    journal.unlink()
    os.mkfifo(journal)
    with pytest.raises(DatasetError) as err:  # O_NONBLOCK: no writer on the FIFO never blocks us
        atomic.replay_journal(journal)
    assert err.value.code == "dataset.unsafe"


def test_batch_never_writes_through_a_planted_staged_symlink(tmp_path: Path) -> None:
    canary = tmp_path / "canary.txt"
    canary.write_text("canary")
    target = tmp_path / "ds" / "meta" / "info.json"
    target.parent.mkdir(parents=True)
    atomic.tmp_name(target).symlink_to(canary)
    atomic.write_with(target, _writes("info"))
    assert canary.read_text() == "canary" and target.read_text() == "info" and not target.is_symlink()


def test_batch_refuses_to_journal_a_file_outside_the_dataset(tmp_path: Path) -> None:
    batch = atomic.Batch(journal=tmp_path / "ds" / ".openral" / "journal.json")
    batch.write_with(tmp_path / "elsewhere.txt", _writes("x"))
    with pytest.raises(DatasetError) as err:
        batch.commit()
    assert err.value.code == "dataset.unsafe" and not (tmp_path / "elsewhere.txt").exists()
    batch.discard()


def test_a_batch_flushes_its_files_together_before_the_journal_names_them(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A journaled batch's staged files are fsynced at once (two flushes in flight together, so the file system
    can group them into one journal commit), each before the journal is written; a flush that fails lands
    nothing: no rename, no journal, the files before stay."""
    meta = tmp_path / "meta"
    meta.mkdir()
    (meta / "f0.json").write_text("old")
    journal = atomic.state_dir(tmp_path) / "journal.json"
    flushed: list[str] = []
    pair = threading.Barrier(2, timeout=20)  # a flush passes only while another one is in flight
    real = atomic.fsync_file
    failing: set[str] = set()

    def fsync(path: Path) -> None:
        if path.name.startswith(".f"):  # the batch's staged files (not the journal's own)
            pair.wait()
            if path.name in failing:
                raise OSError(errno.EIO, os.strerror(errno.EIO), str(path))
        flushed.append(path.name)
        real(path)

    monkeypatch.setattr(atomic, "fsync_file", fsync)
    batch = atomic.Batch(journal=journal)
    for i in range(4):
        batch.write_with(meta / f"f{i}.json", _writes(f"new {i}"))
    batch.commit()
    assert sorted(flushed[:4]) == [f".f{i}.json.tmp" for i in range(4)] and flushed[4] == ".journal.json.tmp"
    assert [(meta / f"f{i}.json").read_text() for i in range(4)] == [f"new {i}" for i in range(4)]
    assert not journal.exists()

    failing.add(".f3.json.tmp")
    batch = atomic.Batch(journal=journal)
    for i in range(4):
        batch.write_with(meta / f"f{i}.json", _writes(f"newer {i}"))
    with pytest.raises(OSError, match=r"f3\.json"):
        batch.commit()
    batch.discard()
    assert [(meta / f"f{i}.json").read_text() for i in range(4)] == [f"new {i}" for i in range(4)]
    assert not journal.exists() and sorted(p.name for p in meta.iterdir()) == [f"f{i}.json" for i in range(4)]
