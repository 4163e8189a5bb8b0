"""What a push uploads: meta/, data/ and videos/ only (mcap/ and .openral/ on request, never the lock or a staged
temporary); a symlink leading out of the dataset, or a FIFO, is refused in one line."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from openral_data.errors import DatasetError
from openral_data.formats.lerobot_v3.lock import DatasetLock
from openral_data.hub import select_files
from tests.support.recorded import record_mock_cli


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return record_mock_cli(tmp_path_factory.mktemp("hub_files"), [3, 100])


@pytest.fixture
def ds(recorded: Path, tmp_path: Path) -> Path:
    """A copy of the mock recording, with a bag in mcap/ and a stray file beside the dataset folders."""
    root = tmp_path / "ds"
    shutil.copytree(recorded, root, symlinks=True)
    (root / "mcap").mkdir()
    (root / "mcap" / "episode_000000.mcap").write_bytes(b"bag")
    (root / "notes.txt").write_text("private notes")
    (root / "data" / "chunk-000" / ".file-001.parquet.tmp").write_bytes(b"staged")
    return root


DATASET = [
    "data/chunk-000/file-000.parquet",
    "meta/episodes/chunk-000/file-000.parquet",
    "meta/info.json",
    "meta/openral.json",
    "meta/stats.json",
    "meta/tasks.parquet",
    "videos/observation.images.front/chunk-000/file-000.mp4",
    "videos/observation.images.wrist/chunk-000/file-000.mp4",
]


def test_only_what_lerobot_reads_by_default(ds: Path) -> None:
    assert (ds / ".openral").is_dir()
    assert select_files(ds) == DATASET


def test_mcap_and_state_only_when_asked(ds: Path) -> None:
    assert select_files(ds, include_mcap=True) == sorted([*DATASET, "mcap/episode_000000.mcap"])
    state = sorted(str(p.relative_to(ds)) for p in (ds / ".openral").rglob("*") if p.is_file())
    assert state  # the recording keeps its bookkeeping there
    with DatasetLock(ds, "test"):  # a lock file is there while held: never uploaded
        assert (ds / ".openral" / "lock").is_file()
        assert select_files(ds, include_state=True) == sorted([*DATASET, *state])


def test_symlink_inside_is_followed(ds: Path) -> None:
    (ds / "meta" / "copy.json").symlink_to(ds / "meta" / "info.json")
    assert "meta/copy.json" in select_files(ds)


@pytest.mark.parametrize("kind", ["file", "folder"])
def test_symlink_out_of_the_dataset_is_refused(ds: Path, tmp_path: Path, kind: str) -> None:
    secret = tmp_path / "outside"
    if kind == "file":
        secret.write_text("secret")
        (ds / "videos" / "leak.mp4").symlink_to(secret)
    else:
        secret.mkdir()
        (secret / "key").write_text("secret")
        (ds / "data" / "chunk-001").symlink_to(secret, target_is_directory=True)
    with pytest.raises(DatasetError) as err:
        select_files(ds)
    assert err.value.code == "dataset.unsafe"
    assert "leads outside" in str(err.value)


def test_a_symlink_loop_inside_is_walked_once(ds: Path) -> None:
    (ds / "data" / "chunk-000" / "again").symlink_to(ds / "data", target_is_directory=True)
    assert select_files(ds).count("data/chunk-000/file-000.parquet") == 1


def test_fifo_is_refused(ds: Path) -> None:
    os.mkfifo(ds / "meta" / "pipe.json")
    with pytest.raises(DatasetError) as err:
        select_files(ds)
    assert err.value.code == "dataset.unsafe"


def test_broken_symlink_is_refused(ds: Path) -> None:
    (ds / "meta" / "gone.json").symlink_to(ds / "meta" / "missing.json")
    with pytest.raises(DatasetError) as err:
        select_files(ds)
    assert err.value.code == "dataset.incomplete"
