"""Health checks of a LeRobot v3 dataset: missing files, zero-frame episodes, row counts against the
episodes metadata, non-monotonic or gapped timestamps, NaN/Inf in state/action, video frame counts.

Frame-level checks are one grouped DuckDB scan of the data parquet's scalar columns (rows, NaN/Inf rows and
a proof that the episode's timestamps step regularly); only the episodes it cannot prove regular go through
the ordered window over their timestamps. Video frames are counted from the mp4 packets (PyAV demux, no
decoding), split into episodes by each episode's from/to timestamps.
"""

from __future__ import annotations

from bisect import bisect_left
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import av
import duckdb

from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.layout import FilePos
from openral_data.formats.lerobot_v3.missing import fetch_hint, missing_files
from openral_data.formats.lerobot_v3.video import count_packets
from openral_data.metrics.scan import VectorScan, vector_scan
from openral_data.metrics.sources import DatasetSource
from openral_data.metrics.views import episodes_from, files_sql, ident, query

GAP_FACTOR = 1.5  # a step longer than 1.5 frame periods is a gap
TIMESTAMP_TOLERANCE_S = 1e-4  # lerobot's tolerance_s for timestamp = frame_index / fps


@dataclass(frozen=True)
class Issue:
    dataset: str
    episode: int | None
    check: str
    detail: str

    def row(self) -> dict[str, Any]:
        return {"dataset": self.dataset, "episode": self.episode, "check": self.check, "detail": self.detail}


def check_dataset(con: duckdb.DuckDBPyConnection, ds: DatasetSource, scan: VectorScan | None = None) -> list[Issue]:
    """All checks of one dataset; `scan` (which columns hold NaN/Inf) is computed when not given."""
    issues: list[Issue] = []
    meta = _episode_meta(con, ds)
    missing, no_data = _missing_files(ds, meta)
    issues += missing
    counted = [m for m in meta if int(m["episode_index"]) not in no_data]
    issues += _frame_checks(con, ds, counted, scan if scan is not None else vector_scan(con, ds))
    issues += _video_checks(ds, meta)
    return sorted(issues, key=lambda i: (i.dataset, -1 if i.episode is None else i.episode, i.check))


def _episode_meta(con: duckdb.DuckDBPyConnection, ds: DatasetSource) -> list[dict[str, Any]]:
    wanted = ["episode_index", "length", "data/chunk_index", "data/file_index"]
    for cam in ds.cameras:
        wanted += [f"videos/{cam}/{k}" for k in ("chunk_index", "file_index", "from_timestamp", "to_timestamp")]
    cols = ", ".join(ident(c) if c in ds.episode_columns else f"NULL AS {ident(c)}" for c in wanted)
    names, rows = query(con, f"SELECT {cols} FROM {episodes_from(ds)} ORDER BY episode_index")
    return [dict(zip(names, row, strict=True)) for row in rows]


def _missing_files(ds: DatasetSource, meta: list[dict[str, Any]]) -> tuple[list[Issue], set[int]]:
    """The files the metadata names that are absent (a partial download: `missing.missing_files`), one issue per
    kind (data, each camera's videos, the tasks table) with the `hf download` that fetches them; and the episodes
    whose data is absent (their rows are not counted against their lengths). `meta/stats.json` is not read here
    (`info` and `doctor` say when it is absent)."""
    issues = []
    if int(ds.info.get("total_tasks", 0)) and not (ds.root / ds.tasks_path).is_file():
        issues.append(Issue(ds.label, None, "missing_file", ds.tasks_path))
    gone = missing_files(ds.root, ds.info, meta, ds.cameras)
    for kind in gone.kinds():
        eps = kind.episodes()
        detail = (
            f"{kind.kind}: {kind.summary()} not downloaded, episode(s) {eps[:5]}{' …' if len(eps) > 5 else ''}; "
            f"fetch them: {fetch_hint(ds.root, [kind.pattern])}"
        )
        issues.append(Issue(ds.label, None, "missing_file", detail))
    return issues, {e for eps in gone.data.values() for e in eps}


def _frame_checks(
    con: duckdb.DuckDBPyConnection, ds: DatasetSource, meta: list[dict[str, Any]], scan: VectorScan
) -> list[Issue]:
    """Rows per episode, rows with NaN/Inf, and timestamp steps in row order.

    The step-by-step check is a window over the episode's rows ordered by `index`; it runs only on the
    episodes a cheap per-episode aggregate cannot prove regular (see `regular_sql`), so a healthy dataset is
    read in one plain grouped scan of its scalar columns. NaN/Inf rows are counted in that scan, looking only
    at the columns the vector scan found them in (none, usually).
    """
    issues: list[Issue] = []
    counted: dict[int, tuple[int, int, int, int, float | None]] = {}
    if ds.data_files:
        order = "index" if "index" in ds.data_columns else "frame_index"
        bad = " OR ".join(f"NOT isfinite({e})" for e in scan.non_finite) or "FALSE"
        suspects = set()
        for ep, n, nonfin, regular in query(con, regular_sql(ds, order, bad))[1]:
            counted[int(ep)] = (int(n), 0, 0, int(nonfin), None)
            if not regular:
                suspects.add(int(ep))
        for ep, n, nonmono, gaps, nonfin, max_step in _ordered_checks(con, ds, order, bad, suspects):
            counted[int(ep)] = (int(n), int(nonmono), int(gaps), int(nonfin), max_step)
    known = set()
    for ep in meta:
        index = int(ep["episode_index"])
        known.add(index)
        length = ep["length"]
        n = counted.get(index, (0, 0, 0, 0, None))[0]
        if not length or n == 0:
            issues.append(Issue(ds.label, index, "zero_frames", f"metadata length {length}, {n} parquet rows"))
        elif n != length:
            issues.append(Issue(ds.label, index, "frame_count", f"metadata length {length}, {n} parquet rows"))
    for index, (n, nonmono, gaps, nonfin, max_step) in sorted(counted.items()):
        if index not in known:
            issues.append(Issue(ds.label, index, "frame_count", f"{n} parquet rows of an episode not in meta/episodes"))
        if nonmono:
            issues.append(Issue(ds.label, index, "timestamp_non_monotonic", f"{nonmono} step(s) not increasing"))
        if gaps:
            issues.append(
                Issue(ds.label, index, "timestamp_gap", f"{gaps} step(s) > {GAP_FACTOR}/fps, longest {max_step:.4g} s")
            )
        if nonfin:
            what = "state/action/environment_state/reward"
            issues.append(Issue(ds.label, index, "non_finite", f"{nonfin} row(s) with NaN/Inf in {what}"))
    return issues


def grid_tolerance(fps: int) -> float:
    """How far an episode's timestamps may stray from an even 1/fps grid and still prove the step checks
    pass: lerobot's own tolerance (1e-4 s), capped at a fifth of a frame period so that no step can be <= 0
    or longer than GAP_FACTOR periods. Public as a seam: `tests/metrics/test_health_fastpath.py` makes it negative
    to send every episode through the ordered check and compare."""
    return min(TIMESTAMP_TOLERANCE_S, 0.2 / fps)


def regular_sql(ds: DatasetSource, order: str, bad: str) -> str:
    """Per episode: rows, rows where `bad` (NaN/Inf) holds, and whether its timestamp steps are provably regular.

    With o = `index` (or `frame_index` without it), an episode is regular when all its rows sit in one file
    with o - file_row_number constant and max(o) - min(o) = rows - 1 (so its o values are distinct and
    consecutive, no NULLs), and timestamp - o / fps varies by at most `grid_tolerance` (lerobot's rule
    timestamp = frame_index / fps, up to the episode's offset). Then, in o order, every step is one frame
    period +- that tolerance: neither <= 0 nor a gap, exactly what the ordered check would find. Anything
    else (a copied row, a swapped timestamp, rows split across files, a NULL) makes it a suspect.
    """
    src = f"read_parquet({files_sql(ds.data_files)})"
    if "timestamp" not in ds.data_columns:
        return f"SELECT episode_index, count(*), count(*) FILTER ({bad}), FALSE FROM {src} GROUP BY episode_index"
    o = ident(order)
    offset = f"timestamp - {o} / {ds.fps}::DOUBLE"
    return f"""
        SELECT episode_index, count(*), count(*) FILTER ({bad}),
               count({offset}) = count(*)
               AND min(file_index) = max(file_index)
               AND min({o} - file_row_number) = max({o} - file_row_number)
               AND max({o}) - min({o}) = count(*) - 1
               AND max({offset}) - min({offset}) <= {grid_tolerance(ds.fps)!r}
        FROM {src}
        GROUP BY episode_index
    """


def _ordered_checks(
    con: duckdb.DuckDBPyConnection, ds: DatasetSource, order: str, bad: str, episodes: set[int]
) -> list[tuple[Any, ...]]:
    """Rows, non-increasing steps, gaps, NaN/Inf rows and the longest step of `episodes`, by a window over
    their rows in `order` (only the few scalar columns, never the state/action lists)."""
    if not episodes:
        return []
    src = f"read_parquet({files_sql(ds.data_files)})"
    wanted = ", ".join(str(e) for e in sorted(episodes))
    sql = f"""
        SELECT episode_index, count(*), count(*) FILTER (d <= 0), count(*) FILTER (d > {GAP_FACTOR / ds.fps}),
               count(*) FILTER (bad), max(d)
        FROM (
            SELECT episode_index, bad, timestamp - lag(timestamp) OVER (PARTITION BY episode_index ORDER BY o) AS d
            FROM (
                SELECT episode_index, {ident(order)} AS o, timestamp, ({bad}) AS bad FROM {src}
                WHERE episode_index IN ({wanted})
            )
        )
        GROUP BY episode_index
    """
    return query(con, sql)[1]


def _video_checks(ds: DatasetSource, meta: list[dict[str, Any]]) -> list[Issue]:
    issues: list[Issue] = []
    half = 0.5 / ds.fps
    for cam in ds.cameras:
        by_file: dict[Path, list[dict[str, Any]]] = defaultdict(list)
        for ep in meta:
            if ep[f"videos/{cam}/chunk_index"] is None:
                issues.append(Issue(ds.label, int(ep["episode_index"]), "video_frames", f"{cam}: no video metadata"))
                continue
            pos = FilePos(ep[f"videos/{cam}/chunk_index"], ep[f"videos/{cam}/file_index"])
            by_file[layout.template_path(ds.root, ds.info, "video_path", pos, video_key=cam)].append(ep)
        for path, eps in sorted(by_file.items()):
            if not path.is_file():
                continue  # reported as missing_file
            try:
                times = count_packets(path)
            except (av.error.FFmpegError, ValueError, IndexError) as exc:
                issues.append(Issue(ds.label, None, "video_frames", f"{path.relative_to(ds.root)}: unreadable: {exc}"))
                continue
            for ep in eps:
                lo = float(ep[f"videos/{cam}/from_timestamp"]) - half
                hi = float(ep[f"videos/{cam}/to_timestamp"]) - half
                frames = bisect_left(times, hi) - bisect_left(times, lo)
                if frames != ep["length"]:
                    issues.append(
                        Issue(
                            ds.label,
                            int(ep["episode_index"]),
                            "video_frames",
                            f"{cam}: {frames} video frame(s), {ep['length']} parquet rows",
                        )
                    )
    return issues
