"""`info DATASET`: a LeRobot dataset's summary (any version) and its cached quality flags, without the convert
stack (the source registry, `convert.kinds.lerobot`, describes a dataset with this too): `info` on a dataset
folder comes here directly, so it starts without importing the bag readers."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from openral_data.errors import OpenralError

if TYPE_CHECKING:
    from openral_data.formats.lerobot_v3 import DatasetSummary


@dataclass
class DatasetInfo:
    """`info DATASET`: the summary of a LeRobot dataset of any version, and its cached quality flags."""

    path: Path
    summary: DatasetSummary
    quality: dict[str, int] | None  # episodes flagged per quality flag (`flag_counts`), None: not computed

    def to_json(self) -> dict[str, Any]:
        return {**self.summary.to_json(), "quality": self.quality}

    def rows(self) -> list[tuple[str, str]]:
        from openral_data.formats.lerobot_v3.reader import LEGACY_VERSIONS as legacy

        s = self.summary
        return [
            ("episodes", str(s.episodes)),
            ("frames", str(s.frames)),
            ("fps", str(s.fps)),
            ("duration", f"{s.frames / s.fps:.1f} s"),
            ("cameras", ", ".join(s.cameras) or "-"),
            ("tasks", "; ".join(s.tasks) or "-"),
            ("robot", s.robot_type or "-"),
            ("success rate", _success_cell(s)),
            *([("format", f"LeRobot {s.codebase_version} (read in place)")] if s.codebase_version in legacy else []),
            *([("missing", line.removeprefix("missing: "))] if s.missing and (line := s.missing.line()) else []),
            ("quality", _quality_cell(self.quality)),
        ]


def describe_dataset(path: Path) -> DatasetInfo:
    """`path` summarised as a LeRobot dataset (one line when it is none)."""
    from openral_data.formats.dataset import summarize

    summary = summarize(path)
    return DatasetInfo(path, summary, _flag_counts(path))


def _flag_counts(path: Path) -> dict[str, int] | None:
    """The cached quality table's flag counts, None when there is none current (or the dataset cannot be opened
    for DuckDB). No table at all is seen without opening the dataset: `info` then imports neither DuckDB nor
    the quality measures."""
    from openral_data.metrics.quality.cache import cache_paths

    try:
        if not cache_paths(path).episodes.is_file():
            return None
        from openral_data.metrics.quality import flag_counts
        from openral_data.metrics.sources import open_dataset

        return flag_counts(open_dataset(path))
    except OpenralError:
        return None


def _quality_cell(counts: dict[str, int] | None) -> str:
    """`2 of 8 episodes flagged (idle 1, camera_black 1)`, else how to get one."""
    if counts is None:
        return "not computed (openral-data quality DATASET)"
    from openral_data.metrics.quality import raised_text

    raised = raised_text(counts)
    return f"{counts['flagged']} of {counts['episodes']} episodes flagged" + (f" ({raised})" if raised else "")


def _success_cell(s: DatasetSummary) -> str:
    """`50.0% (1/2)` over the episodes whose success is known (and how many are not), `unknown (N episodes)` when
    none is (never 0 %)."""
    if s.success_rate is None:
        return f"unknown ({s.episodes} episode{'' if s.episodes == 1 else 's'})"
    unknown = s.episodes - s.success_known
    return f"{s.success_rate:.1%} ({s.successes}/{s.success_known}" + (f", {unknown} unknown)" if unknown else ")")
