"""Videos against the episodes table (lerobot-v3-format.md §8, §10.3): every named mp4 exists, each episode
has exactly `length` frames at from_timestamp + k / fps (within the loader's 1e-4 s), and no mp4 is left
that no episode names. Packets are read without decoding (PyAV demux)."""

from __future__ import annotations

import os
from bisect import bisect_left
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import av

from openral_data.doctor.findings import Finding, error, warning
from openral_data.doctor.inspect import Dataset
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.layout import FilePos
from openral_data.formats.lerobot_v3.video import count_packets

TOLERANCE_S = 1e-4


@dataclass(frozen=True)
class Placement:
    episode: int
    length: int
    from_ts: float
    to_ts: float | None


def placements(ds: Dataset, key: str) -> dict[Path, list[Placement]]:
    """Which episodes each mp4 of camera `key` holds, in episode order."""
    assert ds.episodes is not None
    rows: list[dict[str, Any]] = ds.episodes.select(
        [c for c in ds.episodes.column_names if c in {"episode_index", "length"} or c.startswith(f"videos/{key}/")]
    ).to_pylist()
    out: dict[Path, list[Placement]] = defaultdict(list)
    for r in rows[: ds.total("total_episodes")]:
        chunk, file = r.get(f"videos/{key}/chunk_index"), r.get(f"videos/{key}/file_index")
        if chunk is None or file is None or r.get(f"videos/{key}/from_timestamp") is None:
            continue
        to = r.get(f"videos/{key}/to_timestamp")
        p = Placement(int(r["episode_index"]), int(r["length"]), float(r[f"videos/{key}/from_timestamp"]), to)
        out[layout.video_path(ds.root, key, FilePos(int(chunk), int(file)))].append(p)
    return dict(out)


def check_videos(ds: Dataset) -> list[Finding]:
    if ds.episodes is None or not ds.video_keys:
        return []
    if any(f"videos/{k}/from_timestamp" not in ds.episodes.column_names for k in ds.video_keys):
        return []  # reported as missing columns
    out: list[Finding] = []
    for key in ds.video_keys:
        for path, eps in sorted(placements(ds, key).items()):
            out += _check_file(ds, path, eps)
    return out


def _check_file(ds: Dataset, path: Path, eps: list[Placement]) -> list[Finding]:
    rel = ds.rel(path)
    if not os.path.lexists(path):
        return []  # not downloaded: `check_missing`
    if not path.is_file():
        which = [p.episode for p in eps][:5]
        return [error("video.missing", rel, f"missing (episode(s) {which}; lerobot falls back to a Hub download)")]
    try:
        times = count_packets(path)
    except (av.error.FFmpegError, ValueError, IndexError) as exc:
        return [error("video.unreadable", rel, f"unreadable: {exc}")]
    out: list[Finding] = []
    half = 0.5 / ds.fps
    short: list[str] = []
    off: list[int] = []
    for p in eps:
        lo = bisect_left(times, p.from_ts - half)
        hi = bisect_left(times, p.from_ts + p.length / ds.fps - half)
        if hi - lo != p.length:
            short.append(f"episode {p.episode}: {hi - lo} of {p.length}")
            continue
        if any(abs(times[lo + k] - (p.from_ts + k / ds.fps)) > TOLERANCE_S for k in range(p.length)):
            off.append(p.episode)
    regular = len(times) == sum(p.length for p in eps) and all(
        abs(t - k / ds.fps) <= TOLERANCE_S for k, t in enumerate(times)
    )
    if short:
        out.append(
            error(
                "video.frames",
                rel,
                f"frame count differs from the episode length ({'; '.join(short[:3])}; lerobot fails on those frames)",
                repairable=regular,
            )
        )
    if off:
        out.append(
            error(
                "video.timestamps",
                rel,
                f"frames are not at from_timestamp + k/fps within 1e-4 s in episode(s) {off[:5]} (FrameTimestampError)",
                repairable=regular,
            )
        )
    late = [p.episode for p in eps if p.to_ts is None or abs(p.to_ts - (p.from_ts + p.length / ds.fps)) > TOLERANCE_S]
    if late and not short and not off:
        message = f"to_timestamp != from + length/fps in episode(s) {late[:5]} (rows and length disagree)"
        out.append(error("video.to_timestamp", rel, message, True))
    out += _check_ranges(ds, rel, eps, len(times))
    return out


def _check_ranges(ds: Dataset, rel: str, eps: list[Placement], packets: int) -> list[Finding]:
    """The episodes of one file, in episode order, tile it: each starts where the previous one ends (the first
    at 0), none overlaps another, and no frame is left that no episode shows."""
    end = 0.0
    for p in eps:
        if abs(p.from_ts - end) > TOLERANCE_S:
            what = "overlaps or precedes" if p.from_ts < end else "leaves a gap after"
            return [
                error(
                    "video.ranges",
                    rel,
                    f"episode {p.episode} starts at {p.from_ts:.4f} s: it {what} the previous episode's range "
                    f"(ends at {end:.4f} s); episode ranges must be disjoint, in order and contiguous",
                )
            ]
        end = p.from_ts + p.length / ds.fps
    covered = sum(p.length for p in eps)
    if packets > covered:
        return [error("video.ranges", rel, f"{packets - covered} frame(s) belong to no episode's range")]
    return []


def orphan_videos(ds: Dataset) -> list[Path]:
    if ds.episodes is None:
        return []
    named: set[Path] = set()
    for key in ds.video_keys:
        if f"videos/{key}/chunk_index" in ds.episodes.column_names:
            named |= set(placements(ds, key))
    return [p for p in layout.found_files(ds.root, "videos", "*/*/*.mp4") if p not in named]


def check_orphans(ds: Dataset) -> list[Finding]:
    orphans = orphan_videos(ds)
    if not orphans:
        return []
    names = ", ".join(ds.rel(p) for p in orphans[:3]) + (" …" if len(orphans) > 3 else "")
    return [warning("video.orphan", "videos", f"{len(orphans)} mp4 file(s) no episode refers to: {names}", True)]
