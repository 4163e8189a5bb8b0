"""The JSON files of a dataset or results folder, read with the one error message every reader gives."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from openral_data.errors import DatasetError


def read_json(path: Path) -> Any:
    """`path` parsed; a missing file raises `FileNotFoundError` (its caller says what that means), invalid JSON
    an `OpenralError` naming the file."""
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise DatasetError(f"{path}: invalid JSON: {exc}", code="dataset.invalid") from None
