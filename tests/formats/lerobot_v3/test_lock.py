"""The writer lock is a control file: never followed through a symlink, never blocked on by a FIFO, and a
dataset that cannot be written gives one line."""

from __future__ import annotations

import errno
import os
from pathlib import Path

import pytest

from openral_data.errors import DatasetError
from openral_data.formats import atomic
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.lock import DatasetLock, check_settled, holder


def test_lock_refuses_a_symlink_and_leaves_its_target(tmp_path: Path) -> None:
    canary = tmp_path / "canary"
    canary.write_bytes(b"canary")
    (tmp_path / "ds" / ".openral").mkdir(parents=True)
    (tmp_path / "ds" / layout.LOCK_PATH).symlink_to(canary)
    with pytest.raises(DatasetError) as err:
        DatasetLock(tmp_path / "ds", "test").acquire()
    assert err.value.code == "dataset.unsafe" and canary.read_bytes() == b"canary"
    assert holder(tmp_path / "ds") is None


def test_lock_refuses_a_symlinked_state_dir(tmp_path: Path) -> None:
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    (tmp_path / "ds").mkdir()
    (tmp_path / "ds" / ".openral").symlink_to(elsewhere, target_is_directory=True)
    with pytest.raises(DatasetError) as err:
        DatasetLock(tmp_path / "ds", "test").acquire()
    assert err.value.code == "dataset.unsafe" and not any(elsewhere.iterdir())


def test_fifo_lock_neither_blocks_holder_nor_acquire(tmp_path: Path) -> None:
    (tmp_path / ".openral").mkdir()
    os.mkfifo(tmp_path / layout.LOCK_PATH)
    assert holder(tmp_path) is None  # used to block forever in open()
    with pytest.raises(DatasetError) as err:
        DatasetLock(tmp_path, "test").acquire()
    assert err.value.code == "dataset.unsafe"


@pytest.mark.parametrize("code", [errno.EROFS, errno.EACCES])
def test_unwritable_dataset_is_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, code: int) -> None:
    def refuse(path: Path, flags: int = os.O_RDONLY, mode: int = 0o644) -> int:
        raise OSError(code, os.strerror(code), str(path))

    monkeypatch.setattr(atomic, "open_control", refuse)
    with pytest.raises(DatasetError) as err:
        DatasetLock(tmp_path, "test").acquire()
    assert err.value.code == "dataset.readonly" and "\n" not in str(err.value)
    assert holder(tmp_path) is None  # a reader does not need the lock


def test_check_settled_refuses_a_held_or_interrupted_dataset(tmp_path: Path) -> None:
    root = tmp_path / "ds"
    (root / ".openral").mkdir(parents=True)
    check_settled(root, "push")  # nobody writes, nothing interrupted: no error
    with DatasetLock(root, "record --out ds"), pytest.raises(DatasetError) as err:
        check_settled(root, "push")
    assert err.value.code == "dataset.busy"
    assert str(err.value).endswith("; push it once it is done") and "record --out ds" in str(err.value)
    check_settled(root, "push")  # released
    (root / layout.JOURNAL_PATH).symlink_to(tmp_path / "nowhere")  # even a dangling link: a commit was under way
    with pytest.raises(DatasetError) as err:
        check_settled(root, "edit")
    assert err.value.code == "dataset.interrupted" and "doctor --repair" in str(err.value)
