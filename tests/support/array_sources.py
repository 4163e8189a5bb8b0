"""Helpers for the episodic array sources' tests (zarr replay buffers, RLDS): damage a copy of a good source, read
a source through, check a refusal is one line naming the file."""

from __future__ import annotations

import re
import shutil
from collections.abc import Callable
from pathlib import Path

from openral_data.errors import OpenralError
from openral_data.formats.episodic import ArraySource


def damaged(good: Path, bad: Path, damage: Callable[[Path], None]) -> Path:
    """A copy of the source folder `good` at `bad`, then `damage`d."""
    shutil.copytree(good, bad)
    damage(bad)
    return bad


def read_all(source: ArraySource | None) -> int:
    """Every row of every array of every episode read (the way convert reads them); the rows read."""
    assert source is not None
    rows = 0
    try:
        for episode in source.episodes():
            for spec in episode.specs():
                rows += len(episode.read(spec.key, 0, episode.length))
    finally:
        source.close()
    return rows


def assert_one_line(err: OpenralError, path: Path, pattern: str) -> None:
    """`err` is one line that starts with `path` and matches `pattern`."""
    text = str(err)
    assert "\n" not in text and text.startswith(str(path)) and re.search(pattern, text), text
