"""The JSON files of a dataset, bag or results folder, read the one bounded way every reader uses.

Every JSON we read is untrusted, so every reader goes through `parse_json` (text already in hand: a control file
read by `atomic.read_control`, a parquet column) or `load_json`/`read_json` (a file by name). Both bound the
input: a file must be a regular file (`paths.read_regular`: opened ``O_NONBLOCK`` and `fstat`-ed, so a FIFO
or device is refused before it can block), at most `MAX_JSON_BYTES` long, and nested at most `MAX_JSON_DEPTH`
deep (checked without recursion, so a 200,000-deep file is refused, not a `RecursionError`).
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import numpy as np

from openral_data.errors import DatasetError, NotRegularFile
from openral_data.paths import read_regular

MAX_JSON_BYTES = 64 << 20  # info.json/stats.json of a large dataset are a few MB; 64 MiB is far above any we write
MAX_JSON_DEPTH = 100  # ours nest at most ~6 deep; anything this deep is crafted (and would overflow recursion)

_STRING = re.compile(rb'"(?:[^"\\]|\\.)*"', re.DOTALL)
_NOT_BRACKETS = bytes(b for b in range(256) if b not in b"[]{}")
_STEP = np.zeros(256, np.int8)
_STEP[list(b"[{")] = 1
_STEP[list(b"]}")] = -1


def parse_json(data: bytes | str) -> Any:
    """`data` parsed; text that is not UTF-8, invalid JSON or JSON nested deeper than `MAX_JSON_DEPTH` raise a
    `ValueError` saying which (callers name the file)."""
    raw = data.encode() if isinstance(data, str) else data
    try:
        value = json.loads(raw.decode("utf-8"))
    except RecursionError:
        raise ValueError(f"nested more than {MAX_JSON_DEPTH} deep") from None
    except UnicodeDecodeError as exc:
        raise ValueError(f"not UTF-8 text (byte {exc.start})") from None
    if raw.count(b"[") + raw.count(b"{") > MAX_JSON_DEPTH and _depth(raw) > MAX_JSON_DEPTH:
        raise ValueError(f"nested more than {MAX_JSON_DEPTH} deep")
    return value


def _depth(raw: bytes) -> int:
    """How deep the (valid) JSON text `raw` nests: its brackets outside strings, summed in slices (no recursion,
    linear; every string is closed, as the text parsed)."""
    steps = _STEP[np.frombuffer(_STRING.sub(b"", raw).translate(None, _NOT_BRACKETS), np.uint8)]
    level, deepest = 0, 0
    for start in range(0, len(steps), 1 << 20):
        run = np.cumsum(steps[start : start + (1 << 20)], dtype=np.int64) + level
        deepest, level = max(deepest, int(run.max())), int(run[-1])
    return deepest


def load_json(path: Path, limit: int = MAX_JSON_BYTES) -> Any:
    """`path` (symlinks followed) read by `paths.read_regular` and parsed by `parse_json`. A missing file raises
    `FileNotFoundError`; a folder `IsADirectoryError`, a FIFO or device `NotRegularFile` (checked before reading,
    so nothing blocks); a file over `limit` bytes or bad JSON `ValueError`; other read failures `OSError`."""
    return parse_json(read_regular(path, limit))


def read_json(path: Path, limit: int = MAX_JSON_BYTES) -> Any:
    """`path` read by `read_text_file` and parsed by `parse_json`; a missing file raises `FileNotFoundError` (its
    caller says what that means); anything else wrong an `OpenralError` in one line naming the file."""
    raw = read_text_file(path, limit, "a JSON file")
    try:
        return parse_json(raw)
    except ValueError as exc:
        raise DatasetError(f"{path}: invalid JSON: {exc}", code="dataset.invalid") from None


def read_text_file(path: Path, limit: int, expected: str) -> bytes:
    """The bytes of `path` by `paths.read_regular`; a missing file raises `FileNotFoundError`, anything else wrong
    (a folder, a FIFO, over `limit` bytes, unreadable) a one-line `DatasetError` naming the file (`expected`
    says what it should have been: "a JSON file")."""
    try:
        return read_regular(path, limit)
    except FileNotFoundError:
        raise
    except IsADirectoryError:
        raise DatasetError(f"{path}: is a directory, expected {expected}", code="dataset.invalid") from None
    except NotRegularFile as exc:
        raise DatasetError(f"{path}: {exc.strerror}", code="dataset.unsafe") from None
    except OSError as exc:
        raise DatasetError(f"{path}: cannot read: {exc.strerror or exc}", code="dataset.invalid") from None
    except ValueError as exc:
        raise DatasetError(f"{path}: invalid JSON: {exc}", code="dataset.invalid") from None


def parse_field(data: bytes | str, where: str) -> Any:
    """`parse_json` for JSON stored inside another file (a parquet column): bad JSON is a `DatasetError` in one
    line naming `where` (the file, the row and the column)."""
    try:
        return parse_json(data)
    except ValueError as exc:
        raise DatasetError(f"{where}: invalid JSON: {exc}", code="dataset.invalid") from None
