"""Whether an MCAP file can be shown at all: its start magic, and a summary section that its footer points to (what
rerun's MCAP importer needs; it reports a file without them only in its own log, so `view` checks first)."""

from __future__ import annotations

import struct
from pathlib import Path

from mcap.exceptions import McapError
from mcap.reader import make_reader

from openral_data.errors import BagError


def check_summary(path: Path) -> None:
    """A garbage, truncated (no footer) or summary-less MCAP file raises a `BagError` naming it (`bag.invalid`)."""
    try:
        with open(path, "rb") as fh:
            summary = make_reader(fh).get_summary()
    except (McapError, OSError, ValueError, EOFError, struct.error) as exc:
        raise BagError(f"{path}: cannot read MCAP: {exc}", code="bag.invalid") from None
    if summary is None:
        raise BagError(f"{path}: cannot read MCAP: no summary section (cut short?)", code="bag.invalid")
