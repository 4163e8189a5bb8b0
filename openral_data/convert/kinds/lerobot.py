"""LeRobot datasets: v3.0 (`lerobot_v3`) and v2.0/v2.1 read in place (`lerobot_v2`), a folder with
`meta/info.json`. `info` summarises them (episodes, frames, tasks, cameras, success, quality); `convert` exports
their episodes as ROS 2 MCAP bags (`export_mcap`); they are not split (`--workers`) and have no mapping."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from openral_data.convert.kinds.base import (
    Description,
    Plan,
    ProgressFn,
    Request,
    SourceKind,
    StartingMapping,
    no_starting_mapping,
)
from openral_data.errors import OpenralError, UsageError
from openral_data.metrics.dataset_info import describe_dataset

if TYPE_CHECKING:
    from openral_data.convert.to_mcap import ExportSummary
    from openral_data.formats.mcap import McapConfig


def codebase_version(path: Path) -> str | None:
    """`meta/info.json`'s codebase_version, None when `path` has none (or an unreadable one)."""
    from openral_data.formats.jsonfile import load_json
    from openral_data.formats.lerobot_v3 import layout

    try:
        info = load_json(path / layout.INFO_PATH)
    except (OSError, ValueError, OpenralError):
        return None
    version = info.get("codebase_version") if isinstance(info, dict) else None
    return version if isinstance(version, str) else None


class LeRobotV3Kind(SourceKind[Path]):
    name = "lerobot-v3"
    summary = "LeRobot v3.0 datasets (exported to ROS 2 MCAP bags)"

    def open(self, path: Path) -> Path | None:
        from openral_data.convert.to_mcap import is_lerobot_dataset

        return path if is_lerobot_dataset(path) else None

    def describe(self, handle: Path) -> Description:
        return describe_dataset(handle)

    def blocks(self, handle: Path) -> list[Path]:
        return [handle]

    def open_block(self, src: Path, files: list[Path]) -> Path | None:
        return src

    def starting_mapping(self, handle: Path, fps: int | None) -> StartingMapping:
        raise no_starting_mapping(handle)

    def plan(self, handle: Path, dst: Path, request: Request) -> Plan:
        from openral_data.formats.mcap import McapConfig, parse_compression, parse_image_format

        if request.parallel is not None:
            raise UsageError(
                f"{handle}: is a LeRobot dataset (exported to MCAP); --workers/--executor apply to bags only"
            )
        if request.mapping is not None:
            raise UsageError(f"{handle}: is a LeRobot dataset (exported to MCAP); --mapping applies to bags only")
        image = parse_image_format(request.image_format)  # `--image-format`, `--mcap-compression`: MCAP only
        mcap = McapConfig(image_format=image, compression=parse_compression(request.mcap_compression))
        return ExportPlan(handle, dst, request.episodes, mcap)


class LeRobotV2Kind(LeRobotV3Kind):
    name = "lerobot-v2"
    summary = "LeRobot v2.0 / v2.1 datasets, read in place (exported to ROS 2 MCAP bags)"

    def open(self, path: Path) -> Path | None:
        from openral_data.formats.lerobot_v3.reader import LEGACY_VERSIONS

        return path if super().open(path) is not None and codebase_version(path) in LEGACY_VERSIONS else None


class ExportPlan(Plan):
    what = "exporting"
    done = "exported"
    unit = "frames"

    def __init__(self, src: Path, dst: Path, episodes: str | None, mcap: McapConfig) -> None:
        super().__init__(src, dst)
        self.episodes = episodes
        self.mcap = mcap

    def run(self, progress: ProgressFn | None = None) -> ExportSummary:
        from openral_data.convert.to_mcap import export_mcap

        return export_mcap(self.src, self.dst, episodes=self.episodes, config=self.mcap, progress=progress)

    def to_json(self, summary: ExportSummary) -> dict[str, Any]:
        return summary.to_json()

    def rows(self, summary: ExportSummary) -> list[tuple[str, str]]:
        from openral_data.convert.kinds.report import export_rows

        return export_rows(self.src, self.dst, summary)
