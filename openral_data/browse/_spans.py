"""The frame spans of an episode's quality findings, drawn on the episode page's plots and video timeline: read
from the quality tables `openral-data quality` cached (the `quality`, `quality_frames` and
`quality_camera_frames` views of the catalog's connection; nothing is computed here), one span per run of idle
frames, per dimension frozen to the end, and per run of sampled camera frames with a fault. Each is
{check, subject, start_frame, end_frame, value, threshold}: `subject` is "episode", a feature's dimension
(`observation.state[x]`, drawn on that feature's plot) or a camera; the frames are inclusive."""

from __future__ import annotations

from typing import Any

import duckdb

from openral_data.metrics.quality import DEFAULT
from openral_data.metrics.quality.table import CAMERA_MEASURES

# what each camera fault measures (its mean over the span is the value) and the threshold it is measured against
_CAMERA = {
    "black": ("luma", DEFAULT.black_luma),
    "saturated": ("luma", DEFAULT.saturated_luma),
    "frozen": ("change", DEFAULT.frozen_diff),
    "blurred": ("sharpness", DEFAULT.blur_var),
}
_SPEED = "greatest(coalesce(state_speed, 0), coalesce(action_speed, 0))"


def quality_spans(con: duckdb.DuckDBPyConnection, episode: int, length: int) -> list[dict[str, Any]]:
    """Episode `episode`'s findings with their frames (`length` frames long), in frame order; [] when no current
    quality table is cached. The caller holds the connection's lock."""
    row = con.execute("SELECT frozen_dims, camera_stride FROM quality WHERE episode_index = ?", [episode]).fetchall()
    if not row:
        return []
    frozen, stride = row[0][0], row[0][1] or 1
    spans = [
        _span("idle", "episode", a, b, speed, DEFAULT.idle_speed)
        for a, b, speed in _runs(con, "quality_frames", "idle", _SPEED, episode, 1)
    ]
    for f in frozen or []:
        subject = f"{f['feature']}[{f['name']}]"
        frames = length - f["from_frame"]
        spans.append(_span("frozen", subject, f["from_frame"], length - 1, frames, DEFAULT.frozen_min_frames))
    for measure in CAMERA_MEASURES:
        column, threshold = _CAMERA[measure]
        for a, b, value, camera in _runs(con, "quality_camera_frames", measure, column, episode, stride, "camera"):
            end = min(length - 1, b + stride - 1)  # a sample stands for the frames up to the next one
            spans.append(_span(f"camera_{measure}", camera, a, end, value, threshold))
    return sorted(spans, key=lambda s: (s["start_frame"], s["check"]))


def _span(check: str, subject: str, start: int, end: int, value: Any, threshold: float) -> dict[str, Any]:
    return {
        "check": check,
        "subject": subject,
        "start_frame": int(start),
        "end_frame": int(end),
        "value": round(float(value), 4) if value is not None else None,
        "threshold": threshold,
    }


def _runs(
    con: duckdb.DuckDBPyConnection, view: str, flag: str, measure: str, episode: int, step: int, by: str = ""
) -> list[tuple[Any, ...]]:
    """Runs of consecutive rows of `view` (frames `step` apart, per `by` column when given) where boolean column
    `flag` holds: (first frame, last frame, mean of `measure`[, by]) each. Names are ours, never the user's."""
    key = f", {by}" if by else ""
    sql = (
        f"SELECT min(frame_index), max(frame_index), avg({measure}){key} FROM ("
        f"SELECT *, frame_index // {int(step)} - row_number() OVER (PARTITION BY episode_index{key} "
        f"ORDER BY frame_index) AS run FROM {view} WHERE episode_index = ? AND {flag}) GROUP BY run{key} ORDER BY 1"
    )
    return con.execute(sql, [episode]).fetchall()
