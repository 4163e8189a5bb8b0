"""paths.contained / safe_name: a path taken from a file's contents stays inside its root."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from openral_data.errors import DatasetError
from openral_data.formats import atomic
from openral_data.paths import contained, contained_all, safe_name


@pytest.mark.parametrize("rel", ["data/chunk-000/file-000.parquet", "a/b", "videos/x.y/c"])
def test_contained_accepts_paths_inside(tmp_path: Path, rel: str) -> None:
    assert contained(tmp_path, rel, "f: k") == tmp_path / rel


@pytest.mark.parametrize("rel", ["../x", "a/../../x", "/etc/passwd", "a/..", "a\x00b"])
def test_contained_refuses_paths_leaving(tmp_path: Path, rel: str) -> None:
    with pytest.raises(DatasetError) as err:
        contained(tmp_path, rel, "meta/info.json: data_path")
    assert err.value.code == "dataset.unsafe"
    assert str(err.value).startswith("meta/info.json: data_path: ")


@pytest.mark.parametrize("rel", ["../x", "a/../../x", "/etc/passwd", "a/..", "a\x00b"])
def test_contained_all_refuses_what_contained_refuses(tmp_path: Path, rel: str) -> None:
    inside = ["data/chunk-000/file-000.parquet", "data/chunk-000/file-001.parquet", "a/b"]
    assert contained_all(tmp_path, inside, "j") == [tmp_path / r for r in inside]
    with pytest.raises(DatasetError) as err:
        contained_all(tmp_path, [*inside, rel], "j")
    assert err.value.code == "dataset.unsafe"


def test_contained_all_refuses_a_symlinked_folder_or_file_out(tmp_path: Path) -> None:
    root, outside = tmp_path / "root", tmp_path / "outside"
    (root / "data").mkdir(parents=True)
    outside.mkdir()
    (root / "data" / "file-000.parquet").symlink_to(outside / "x")
    with pytest.raises(DatasetError):
        contained_all(root, ["data/file-001.parquet", "data/file-000.parquet"], "x")
    (root / "videos").symlink_to(outside)
    with pytest.raises(DatasetError):
        contained_all(root, ["videos/cam/file.mp4"], "x")


def test_contained_refuses_a_symlink_out(tmp_path: Path) -> None:
    root, outside = tmp_path / "root", tmp_path / "outside"
    root.mkdir()
    outside.mkdir()
    (root / "videos").symlink_to(outside)
    with pytest.raises(DatasetError):
        contained(root, "videos/cam/file.mp4", "x")


@pytest.mark.parametrize("name", ["", ".", "..", "a/b", "a\\b", "a\x00", 3, None])
def test_safe_name_refuses(name: object) -> None:
    with pytest.raises(DatasetError):
        safe_name(name, "pipeline.yaml: robots[0].id")


def test_safe_name_accepts_feature_keys() -> None:
    assert safe_name("observation.images.top", "x") == "observation.images.top"


def test_open_control_refuses_symlink_and_fifo(tmp_path: Path) -> None:
    target = tmp_path / "canary"
    target.write_text("keep")
    (tmp_path / "link").symlink_to(target)
    os.mkfifo(tmp_path / "fifo")
    for name in ("link", "fifo"):
        with pytest.raises(DatasetError) as err:
            atomic.open_control(tmp_path / name, os.O_RDWR | os.O_CREAT)
        assert err.value.code == "dataset.unsafe"
    assert target.read_text() == "keep"
    (tmp_path / "ok").write_bytes(b"x")
    assert atomic.read_control(tmp_path / "ok") == b"x"


def test_state_dir_refuses_a_symlink(tmp_path: Path) -> None:
    (tmp_path / "elsewhere").mkdir()
    root = tmp_path / "ds"
    root.mkdir()
    (root / ".openral").symlink_to(tmp_path / "elsewhere")
    with pytest.raises(DatasetError):
        atomic.state_dir(root)
    assert atomic.state_dir(tmp_path / "fresh").is_dir()


def test_regular_file_refuses_a_fifo_and_a_folder(tmp_path: Path) -> None:
    from openral_data.paths import regular_file

    os.mkfifo(tmp_path / "fifo")
    for path in (tmp_path / "fifo", tmp_path):
        with pytest.raises(DatasetError) as err:
            regular_file(path)
        assert err.value.code == "dataset.unsafe"
    (tmp_path / "f").write_bytes(b"")
    assert regular_file(tmp_path / "f") == tmp_path / "f"
