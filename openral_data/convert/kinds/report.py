"""The summary tables `convert` prints (without `--json`): bags -> LeRobot, array source -> LeRobot,
LeRobot -> MCAP; one (name, value) row each."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from openral_data.convert.kinds.base import Parallel
    from openral_data.convert.summary import ConvertSummary
    from openral_data.convert.to_mcap import ExportSummary
    from openral_data.formats.episodic import ArraySource
    from openral_data.schemas.mapping import Mapping

Rows = list[tuple[str, str]]


def _workers(parallel: Parallel | None) -> Rows:
    return [("workers", f"{parallel.workers} ({parallel.executor})")] if parallel is not None else []


def bag_rows(src: Path, dst: Path, mapping: Mapping, result: ConvertSummary, parallel: Parallel | None) -> Rows:
    """The summary table of a bags -> LeRobot conversion."""
    rows = [
        ("source", f"{src} ({result.bags} bag(s))"),
        *_workers(parallel),
        ("output", str(dst)),
        ("episodes", str(len(result.episodes))),
        (
            "frames",
            f"{result.frames} at {mapping.fps} fps ({mapping.align.method}, max staleness "
            f"{mapping.align.max_staleness:g} s)",
        ),
        ("frames/s", f"{result.fps:.1f}"),
    ]
    for topic, rep in result.topics.items():
        rows.append(
            (
                f"mapped {topic}",
                f"{rep.msgtype}: {rep.messages} msgs, {rep.used} used, {rep.unused} unused (superseded or outside "
                f"every frame), {rep.unfillable_frames} frames unfillable",
            )
        )
    rows.append(
        (
            "unfillable frames",
            f"{result.unfillable_frames} skipped, never zero-filled ({result.splits} episode split(s) at gaps, "
            f"{result.empty_segments} source episode(s) without a single filled frame)",
        )
    )
    if mapping.align.clock == "header":
        rows.append(
            (
                "late messages",
                f"{result.late_messages} not used (stamp more than align.reorder behind the newest stamp read)",
            )
        )
    rows.append(("outcomes", _outcomes(mapping)))
    for topic, count in sorted(result.skipped_topics.items()):
        rows.append((f"skipped {topic}", f"{count} msgs (not in the mapping)"))
    for topic, count in sorted(result.trailing_bytes.items()):
        rows.append(
            (
                f"trailing bytes {topic}",
                f"{count} msgs with bytes after their last field (ignored, as ROS 1's own reader does)",
            )
        )
    return rows


def _outcomes(mapping: Mapping) -> str:
    reward = (
        f"reward from {mapping.reward.topic}" if mapping.reward is not None else "no reward (no next.reward column)"
    )
    if mapping.success is None:
        success = "success unknown (no next.success column, episode success NULL)"
    else:
        parts = [p for p in (mapping.success.topic, "end markers" if mapping.success.marker else None) if p]
        success = "success from " + " + ".join(parts)
    return f"{reward}; {success}; done on each episode's last frame"


def array_rows(
    source: ArraySource, dst: Path, mapping: Mapping, result: ConvertSummary, parallel: Parallel | None
) -> Rows:
    """The summary table of an array source -> LeRobot conversion."""
    rows = [
        ("source", f"{source.path} ({source.layout}, {result.bags} file(s))"),
        *_workers(parallel),
        ("output", str(dst)),
        ("episodes", str(len(result.episodes))),
        ("frames", f"{result.frames} at {mapping.fps} fps (one frame a step)"),
        ("frames/s", f"{result.fps:.1f}"),
    ]
    for key, rep in result.topics.items():
        rows.append((f"mapped {key}", f"{rep.msgtype}: {rep.messages} steps"))
    reward = f"reward from {mapping.reward.topic}" if mapping.reward is not None else "no reward"
    success = f"success from {mapping.success.topic}" if mapping.success is not None else "success unknown"
    rows.append(("outcomes", f"{reward}; {success}; done on each episode's last frame"))
    return rows


def export_rows(src: Path, dst: Path, summary: ExportSummary) -> Rows:
    """The summary table of a LeRobot -> MCAP export."""
    return [
        ("source", str(src)),
        ("output", f"{dst} (one rosbag2/MCAP bag per episode)"),
        ("episodes", ", ".join(str(e.index) for e in summary.episodes)),
        ("frames", str(summary.frames)),
        ("frames/s", f"{summary.fps:.1f}"),
        ("not exported", ", ".join(summary.skipped_features) or "-"),
    ]
