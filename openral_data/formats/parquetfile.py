"""The parquet files of a dataset or results folder, read with the one error message every reader gives: a
missing, empty, truncated or garbage file is an `OpenralError` naming it, never a pyarrow traceback."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

from openral_data.errors import DatasetError
from openral_data.paths import regular_file


def _refused(path: Path, exc: Exception) -> DatasetError:
    if isinstance(exc, FileNotFoundError):
        return DatasetError(f"{path}: missing", code="dataset.incomplete")
    if isinstance(exc, IsADirectoryError):
        return DatasetError(f"{path}: is a directory, expected a parquet file", code="dataset.invalid")
    reason = (str(exc).splitlines() or [type(exc).__name__])[0]
    reason = reason.split(f"'{path}': ", 1)[-1]  # pyarrow repeats the path
    return DatasetError(f"{path}: unreadable parquet: {reason}", code="dataset.invalid")


def checked(path: Path) -> Path:
    """`path` if pyarrow or DuckDB may open it: a regular file (`paths.regular_file`, so a FIFO or a device cannot
    block the reader), not a folder (pyarrow would read one as a partitioned dataset) and present."""
    if path.is_dir():
        raise _refused(path, IsADirectoryError())
    try:
        return regular_file(path)
    except FileNotFoundError as exc:
        raise _refused(path, exc) from None


def read_table(path: Path, columns: Sequence[str] | None = None, **kwargs: Any) -> pa.Table:
    """`pq.read_table(path, columns, **kwargs)`, fully validated (offsets, UTF-8 of every string), so later
    conversions cannot fail on damaged values; an unreadable file raises a `DatasetError` naming it."""
    try:
        table = _read(checked(path), columns, **kwargs)
        table.validate(full=True)
        _ = table.column_names  # a column name that is not UTF-8 fails here, not in a later reader
    except (pa.ArrowException, OSError, UnicodeDecodeError) as exc:
        raise _refused(path, exc) from None
    return table


def _read(path: Path, columns: Sequence[str] | None, **kwargs: Any) -> pa.Table:
    if kwargs:  # a read that filters rows (`filters=`) goes through pyarrow.dataset
        return pq.read_table(path, columns=columns, **kwargs)
    return read_raw(path, columns)


def read_raw(path: Path, columns: Sequence[str] | None = None, *, verify_pages: bool = False) -> pa.Table:
    """`pq.read_table(path, columns=columns)` of one file, unchecked (pyarrow's errors pass), through
    `pq.ParquetFile`: `pq.read_table` imports pyarrow.dataset and with it pandas, ~0.5 s that `info` and `doctor`
    need not pay. `verify_pages` checks every page's checksum (a flipped byte is an error, not a value)."""
    with pq.ParquetFile(path, page_checksum_verification=verify_pages) as file:
        table = file.read(columns=None if columns is None else list(columns))
        names = file.schema_arrow.names
    return table if columns is None else _exact(table, columns, names)


def _exact(table: pa.Table, columns: Sequence[str], names: Sequence[str]) -> pa.Table:
    # ParquetFile also takes a name as a dotted prefix of nested columns: keep the exact names, in the order asked
    for name in columns:
        if name not in table.column_names:
            raise pa.ArrowInvalid(f"No match for FieldRef.Name({name}) in {', '.join(names)}")
    return table.select(list(columns))


def read_row_groups(path: Path, columns: Sequence[str]) -> Iterator[pa.Table]:
    """`read_table(path, columns)` one row group at a time (memory bounded by the largest row group, not the
    file), each validated as `read_table` validates the whole; an unreadable file raises a `DatasetError` naming
    it, a missing column before any row group is read."""
    try:
        with pq.ParquetFile(checked(path)) as file:
            names = file.schema_arrow.names
            _exact(file.schema_arrow.empty_table(), columns, names)
            for group in range(file.num_row_groups):
                table = _exact(file.read_row_group(group, columns=list(columns)), columns, names)
                table.validate(full=True)
                yield table
    except (pa.ArrowException, OSError, UnicodeDecodeError) as exc:
        raise _refused(path, exc) from None


def read_schema(path: Path) -> pa.Schema:
    """`pq.read_schema(path)`; an unreadable file raises a `DatasetError` naming it."""
    try:
        schema = pq.read_schema(checked(path))
        _ = schema.names
    except (pa.ArrowException, OSError, UnicodeDecodeError) as exc:
        raise _refused(path, exc) from None
    return schema


def num_rows(path: Path) -> int:
    """The row count in `path`'s footer; an unreadable file raises a `DatasetError` naming it."""
    try:
        return int(pq.read_metadata(checked(path)).num_rows)
    except (pa.ArrowException, OSError, UnicodeDecodeError) as exc:
        raise _refused(path, exc) from None
