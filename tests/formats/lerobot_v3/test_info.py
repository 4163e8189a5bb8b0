"""formats/lerobot_v3/info.py: the types readers rely on in meta/info.json, refused naming the key."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from openral_data.errors import DatasetError
from openral_data.formats.lerobot_v3.info import check_info

GOOD: dict[str, Any] = {
    "codebase_version": "v3.0",
    "robot_type": None,
    "fps": 20,
    "total_episodes": 2,
    "total_frames": 6,
    "total_tasks": 1,
    "chunks_size": 1000,
    "features": {"action": {"dtype": "float32", "shape": [7]}},
}
PATH = Path("ds/meta/info.json")


def test_a_good_info_passes() -> None:
    assert check_info(dict(GOOD), PATH) == GOOD


@pytest.mark.parametrize(
    ("change", "key"),
    [
        ({"fps": 0}, "fps"),
        ({"fps": -5}, "fps"),
        ({"fps": 20.5}, "fps"),
        ({"fps": True}, "fps"),
        ({"fps": "20"}, "fps"),
        ({"fps": 10**6}, "fps"),
        ({"fps": ...}, "fps"),
        ({"features": ["action"]}, "features"),
        ({"features": ...}, "features"),
        ({"features": {"action": [1]}}, "features.action"),
        ({"total_episodes": -1}, "total_episodes"),
        ({"total_frames": "6"}, "total_frames"),
        ({"chunks_size": 0}, "chunks_size"),
        ({"robot_type": 3}, "robot_type"),
        ({"data_path": ["x"]}, "data_path"),
    ],
)
def test_a_wrong_type_names_the_key(change: dict[str, Any], key: str) -> None:
    info = {**GOOD, **change}
    for k, v in change.items():
        if v is ...:
            del info[k]
    with pytest.raises(DatasetError) as err:
        check_info(info, PATH)
    assert err.value.code == "dataset.invalid"
    assert str(err.value).startswith(f"{PATH}: {key}: "), str(err.value)


@pytest.mark.parametrize("info", [[], "x", 3, None])
def test_not_an_object(info: Any) -> None:
    with pytest.raises(DatasetError, match="expected a JSON object"):
        check_info(info, PATH)
