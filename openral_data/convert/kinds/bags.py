"""What the bag source kinds (ROS 1 bags, rosbag2 / MCAP) share: `info` lists every topic from the bags'
indexes, `--print-mapping` guesses a mapping from the topics (`guess_mapping`), a conversion aligns the mapped
topics to the mapping's fps (`convert_bags`, or `convert_parallel` over blocks of bags). A kind of them says
only which paths it takes."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from openral_data.convert.kinds.base import Description, Plan, ProgressFn, Request, SourceKind, StartingMapping
from openral_data.errors import UsageError

if TYPE_CHECKING:
    from openral_data.convert.summary import ConvertSummary
    from openral_data.schemas.mapping import Mapping


class BagKind(SourceKind[Path]):
    def describe(self, handle: Path) -> Description:
        from openral_data.convert.discover import describe_bags

        return describe_bags(handle)

    def blocks(self, handle: Path) -> list[Path]:
        from openral_data.convert.sources import find_bags

        return find_bags(handle)

    def open_block(self, src: Path, files: list[Path]) -> Path | None:
        return src  # a block is the bags themselves (`convert_bags(bags=...)`)

    def starting_mapping(self, handle: Path, fps: int | None) -> StartingMapping:
        from openral_data.convert.guess_mapping import guess_mapping, mapping_yaml

        if fps is not None:
            raise UsageError(
                "--fps applies to array sources; a bag's starting mapping guesses its rate from the topics"
            )
        guess = guess_mapping(handle)
        return StartingMapping(handle, "bag", guess.mapping, guess.notes, mapping_yaml(handle, guess))

    def plan(self, handle: Path, dst: Path, request: Request) -> Plan:
        from openral_data.schemas.mapping import load_mapping

        if request.fps is not None:
            raise UsageError("--fps applies to array sources (HDF5, Zarr, RLDS); a bag's rate is its mapping's fps")
        if request.episodes is not None:
            raise UsageError("--episodes selects episodes of a LeRobot dataset; SRC is a bag")
        given = request.mapping
        mapping = load_mapping(given) if isinstance(given, Path) else given or self.default_mapping(handle)
        return BagPlan(handle, dst, mapping, request)

    def default_mapping(self, handle: Path) -> Mapping:
        """The mapping without `--mapping`: our own bags' (their start markers)."""
        from openral_data.convert.own_bags import own_bags_mapping

        return own_bags_mapping(self.blocks(handle))


class BagPlan(Plan):
    unit = "messages"

    def __init__(self, src: Path, dst: Path, mapping: Mapping, request: Request) -> None:
        super().__init__(src, dst)
        self.mapping = mapping
        self.request = request

    def run(self, progress: ProgressFn | None = None) -> ConvertSummary:
        from openral_data.convert.parallel import convert_parallel
        from openral_data.convert.to_lerobot import convert_bags

        video, p = self.request.video, self.request.parallel
        if p is None:
            return convert_bags(self.src, self.dst, self.mapping, video=video, progress=progress)
        return convert_parallel(
            self.src, self.dst, self.mapping, p.workers, executor=p.executor, address=p.address, video=video,
            progress=progress,
        )  # fmt: skip

    def to_json(self, summary: ConvertSummary) -> dict[str, Any]:
        p = self.request.parallel
        return summary.to_json(self.mapping) if p is None else summary.to_json(self.mapping, p.workers, p.executor)

    def rows(self, summary: ConvertSummary) -> list[tuple[str, str]]:
        from openral_data.convert.kinds.report import bag_rows

        return bag_rows(self.src, self.dst, self.mapping, summary, self.request.parallel)
