"""`.openral/digests.json`: what a commit hashes, what it keeps, and what `changed` reports."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from openral_data.errors import DatasetError
from openral_data.formats import atomic
from openral_data.formats.lerobot_v3 import digests, layout

DATA = "data/chunk-000/file-000.parquet"


def _dataset(root: Path) -> Path:
    (root / "data/chunk-000").mkdir(parents=True)
    (root / DATA).write_bytes(b"frames v1")
    (root / "meta").mkdir()
    (root / layout.STATS_PATH).write_bytes(b"{}")
    return root


def test_staged_files_are_hashed_and_info_comes_from_memory(tmp_path: Path) -> None:
    root = _dataset(tmp_path)
    atomic.tmp_name(root / DATA).write_bytes(b"frames v2")  # staged in this commit: hashed instead of the file
    m = digests.compute(root, {}, {layout.INFO_PATH: b"{info}"})
    assert set(m) == {DATA, layout.STATS_PATH, layout.INFO_PATH}
    assert m[DATA]["size"] == len(b"frames v2") and m[layout.INFO_PATH]["size"] == len(b"{info}")
    atomic.tmp_name(root / DATA).replace(root / DATA)
    (root / layout.INFO_PATH).write_bytes(b"{info}")
    assert digests.changed(root, m) == []


def test_a_byte_changed_in_place_is_not_taken_over_by_the_next_commit(tmp_path: Path) -> None:
    root = _dataset(tmp_path)
    first = digests.compute(root, {}, {})
    with open(root / DATA, "r+b") as fh:  # same inode, same size: not a write of ours
        fh.write(b"F")
    second = digests.compute(root, first, {})
    assert second[DATA] == first[DATA]
    assert digests.changed(root, second) == [(DATA, "content differs from what was written (sha256)")]
    atomic.write_bytes(root / DATA, b"frames v3")  # our writes replace by rename: a new inode, hashed again
    assert digests.changed(root, digests.compute(root, second, {})) == []


def test_stored_keys_stay_inside_the_dataset(tmp_path: Path) -> None:
    root = _dataset(tmp_path)
    (root / ".openral").mkdir()
    (root / digests.DIGESTS_PATH).write_text(json.dumps({"../outside": {"sha256": "0" * 64, "size": 1}}))
    with pytest.raises(DatasetError) as excinfo:
        digests.read(root)
    assert excinfo.value.code == "dataset.unsafe"
    (root / digests.DIGESTS_PATH).write_text("[1, 2]")
    with pytest.raises(DatasetError) as excinfo:
        digests.read(root)
    assert excinfo.value.code == "dataset.invalid"
