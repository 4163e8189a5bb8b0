"""formats/parquetfile.py: every way a parquet file can be unreadable is one DatasetError naming it."""

from __future__ import annotations

from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from openral_data.errors import DatasetError
from openral_data.formats.parquetfile import read_row_groups, read_schema, read_table


def _good(path: Path) -> bytes:
    pq.write_table(pa.table({"task_index": [0, 1], "task": ["pick", "place"]}), path)
    return path.read_bytes()


@pytest.mark.parametrize(
    ("damage", "code"),
    [
        ("missing", "dataset.incomplete"),
        ("empty", "dataset.invalid"),
        ("truncated", "dataset.invalid"),
        ("garbage", "dataset.invalid"),
        ("folder", "dataset.invalid"),
        ("bad-utf8-value", "dataset.invalid"),
    ],
)
def test_unreadable_parquet_names_the_file(tmp_path: Path, damage: str, code: str) -> None:
    path = tmp_path / "t.parquet"
    raw = _good(path)
    if damage == "missing":
        path.unlink()
    elif damage == "empty":
        path.write_bytes(b"")
    elif damage == "truncated":
        path.write_bytes(raw[: len(raw) // 2])
    elif damage == "garbage":
        path.write_bytes(b"PAR1" + b"\x00" * 40 + b"PAR1")
    elif damage == "folder":
        path.unlink()
        path.mkdir()
    else:  # same length, so the file still parses: only full validation sees the broken UTF-8
        path.write_bytes(raw.replace(b"place", b"pl\xffce"))

    def by_groups(p: Path) -> list[pa.Table]:
        return list(read_row_groups(p, ["task_index", "task"]))

    for read in (read_table, read_schema, by_groups) if damage != "bad-utf8-value" else (read_table, by_groups):
        with pytest.raises(DatasetError) as err:
            read(path)
        assert err.value.code == code and str(path) in str(err.value) and "\n" not in str(err.value)


def test_a_good_file_reads(tmp_path: Path) -> None:
    path = tmp_path / "t.parquet"
    _good(path)
    assert read_table(path).column("task").to_pylist() == ["pick", "place"]
    assert read_schema(path).names == ["task_index", "task"]
    pq.write_table(pa.table({"task_index": [0, 1, 2], "task": ["a", "b", "c"]}), path, row_group_size=2)
    groups = read_row_groups(path, ["task", "task_index"])
    assert [t.to_pydict() for t in groups] == [
        {"task": ["a", "b"], "task_index": [0, 1]},
        {"task": ["c"], "task_index": [2]},
    ]
    with pytest.raises(DatasetError, match=r"No match for FieldRef\.Name\(index\) in task_index, task"):
        next(read_row_groups(path, ["task", "index"]))  # before any row group is read
