"""The JSON files of a dataset or results folder, read with the one error message every reader gives."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from openral_data.errors import DatasetError


def read_json(path: Path) -> Any:
    """`path` parsed; a missing file raises `FileNotFoundError` (its caller says what that means); a folder, an
    unreadable file, text that is not UTF-8, invalid or too deeply nested JSON an `OpenralError` naming the file."""
    try:
        text = path.read_bytes().decode("utf-8")
    except FileNotFoundError:
        raise
    except IsADirectoryError:
        raise DatasetError(f"{path}: is a directory, expected a JSON file", code="dataset.invalid") from None
    except UnicodeDecodeError as exc:
        raise DatasetError(f"{path}: not UTF-8 text (byte {exc.start})", code="dataset.invalid") from None
    except OSError as exc:
        raise DatasetError(f"{path}: cannot read: {exc.strerror or exc}", code="dataset.invalid") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise DatasetError(f"{path}: invalid JSON: {exc}", code="dataset.invalid") from None
    except RecursionError:
        raise DatasetError(f"{path}: invalid JSON: nested too deeply", code="dataset.invalid") from None
