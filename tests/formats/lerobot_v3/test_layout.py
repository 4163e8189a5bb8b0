"""Paths made from a dataset's contents: feature keys, chunk/file indices and info.json templates."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from openral_data.errors import DatasetError
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.layout import FilePos
from openral_data.formats.lerobot_v3.reader import check_paths


@pytest.mark.parametrize("value", [-1, 10**6, 2**70, 1.5, "3", None, True])
def test_file_pos_refuses_what_is_not_a_small_index(value: object) -> None:
    with pytest.raises(DatasetError) as err:
        FilePos(value, 0)  # type: ignore[arg-type]
    assert err.value.code == "dataset.invalid"


def test_file_pos_takes_numpy_integers() -> None:
    pos = FilePos(np.int64(2), np.int32(3))  # type: ignore[arg-type]
    assert pos == FilePos(2, 3) and type(pos.chunk) is int


@pytest.mark.parametrize("key", ["../x", "a/b", "..", "", "a\\b", "a\x00b"])
def test_video_path_refuses_a_key_that_is_not_one_component(tmp_path: Path, key: str) -> None:
    with pytest.raises(DatasetError) as err:
        layout.video_path(tmp_path, key, FilePos())
    assert err.value.code == "dataset.unsafe"


@pytest.mark.parametrize(
    ("template", "code"),
    [
        ("../x/{chunk_index}.parquet", "dataset.unsafe"),
        ("/etc/{chunk_index}", "dataset.unsafe"),
        ("data/{nope}.parquet", "dataset.invalid"),
        ("data/{chunk_index:q}.parquet", "dataset.invalid"),
        ("data/{", "dataset.invalid"),
        (7, "dataset.invalid"),
    ],
)
def test_template_path_refuses(tmp_path: Path, template: object, code: str) -> None:
    with pytest.raises(DatasetError) as err:
        layout.template_path(tmp_path, {"data_path": template}, "data_path", FilePos())
    assert err.value.code == code and "data_path" in str(err.value)


def test_template_path_standard_and_default(tmp_path: Path) -> None:
    expect = layout.data_path(tmp_path, FilePos(1, 2))
    assert layout.template_path(tmp_path, {"data_path": layout.DATA_PATH}, "data_path", FilePos(1, 2)) == expect
    assert layout.template_path(tmp_path, {}, "data_path", FilePos(1, 2)) == expect


@pytest.mark.parametrize(
    "info",
    [
        {"features": {"../cam": {"dtype": "video"}}},
        {"features": {"cam": {"dtype": "video"}}, "video_path": "../{video_key}/{chunk_index}/{file_index}.mp4"},
        {"features": {}, "data_path": "../{chunk_index}/{file_index}.parquet"},
        {"features": ["a"]},
    ],
)
def test_read_info_check_refuses_paths_leading_outside(tmp_path: Path, info: dict[str, object]) -> None:
    with pytest.raises(DatasetError):
        check_paths(tmp_path, info)


def test_read_info_check_accepts_lerobot_info(tmp_path: Path) -> None:
    info = {
        "features": {"observation.images.front": {"dtype": "video"}, "observation.state": {"dtype": "float32"}},
        "data_path": layout.DATA_PATH,
        "video_path": layout.VIDEO_PATH,
    }
    check_paths(tmp_path, info)
