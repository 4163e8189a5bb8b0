"""JSON Lines metadata (meta/episodes.jsonl, tasks.jsonl, episodes_stats.jsonl), read bounded: a regular file of
at most `MAX_JSONL_BYTES` (`jsonfile.read_text_file`) and `MAX_JSONL_LINES` lines of at most
`MAX_JSONL_LINE_BYTES`, each line parsed by `jsonfile.parse_json` (depth-limited), each an object."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from openral_data.errors import DatasetError
from openral_data.formats.jsonfile import parse_json, read_text_file

MAX_JSONL_BYTES = 256 << 20  # episodes_stats.jsonl of a large dataset holds ~10 KB per episode
MAX_JSONL_LINES = 1_000_000  # episodes or tasks (lerobot's largest v2 datasets hold tens of thousands)
MAX_JSONL_LINE_BYTES = 16 << 20  # one episode's stats


def read_jsonl(path: Path, limit: int = MAX_JSONL_BYTES) -> list[dict[str, Any]]:
    """The objects of `path`, one a line (blank lines skipped); a missing file raises `FileNotFoundError` (the
    caller says what that means), anything else wrong a one-line `DatasetError` naming the file and line."""
    rows: list[dict[str, Any]] = []
    data = read_text_file(path, limit, "a JSON Lines file")
    if data.count(b"\n") > MAX_JSONL_LINES:  # counted before a line is parsed: each row is a dict in memory
        raise DatasetError(f"{path}: more than {MAX_JSONL_LINES} lines", code="dataset.invalid")
    for n, line in enumerate(data.splitlines(), start=1):
        if not line.strip():
            continue
        if len(line) > MAX_JSONL_LINE_BYTES:
            raise DatasetError(f"{path}: line {n}: over {MAX_JSONL_LINE_BYTES} bytes", code="dataset.invalid")
        try:
            row = parse_json(line)
        except ValueError as exc:
            raise DatasetError(f"{path}: line {n}: invalid JSON: {exc}", code="dataset.invalid") from None
        if not isinstance(row, dict):
            raise DatasetError(f"{path}: line {n}: not a JSON object", code="dataset.invalid")
        rows.append(row)
    return rows
