"""The frame spans of an episode's quality findings, drawn on the episode page's plots and video timeline: read
from the `quality_findings` view of the catalog's connection (the findings `openral-data quality` cached,
`metrics.quality.findings`; nothing is computed here). Each is {check, subject, start_frame, end_frame, value,
threshold, flag, detail}: `subject` is "episode", "timestamp", a feature's dimension (`observation.state[x]`,
drawn on that feature's plot) or a camera; the frames are inclusive; `flag` false for an informational check."""

from __future__ import annotations

import math
from typing import Any

import duckdb

_COLUMNS = ("check", "subject", "start_frame", "end_frame", "value", "threshold", "flag", "detail")


def quality_spans(con: duckdb.DuckDBPyConnection, episode: int) -> list[dict[str, Any]]:
    """Episode `episode`'s findings that have frames, in frame order; [] when no current quality table is cached.
    The caller holds the connection's lock."""
    rows = con.execute(
        f"SELECT {', '.join(f'"{c}"' for c in _COLUMNS)} FROM quality_findings "
        "WHERE episode_index = ? AND start_frame IS NOT NULL AND end_frame IS NOT NULL "
        'ORDER BY start_frame, "check", subject',
        [episode],
    ).fetchall()
    out = []
    for row in rows:
        span = dict(zip(_COLUMNS, row, strict=True))
        for key in ("value", "threshold"):
            v = span[key]
            span[key] = round(v, 4) if isinstance(v, float) and math.isfinite(v) else None
        out.append(span)
    return out
