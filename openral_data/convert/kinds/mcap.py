"""MCAP of another profile than ROS 2 (Foxglove's SDKs, the `mcap` library): a ``.mcap`` file of protobuf, JSON
or ROS 1 messages, or a folder of them (`formats.mcap.foreign`). Converted with no mapping written from its
guessed one (`--print-mapping` prints it): Foxglove's well-known schemas and joint-like numbers are mapped as
ROS's types are."""

from __future__ import annotations

from pathlib import Path

from openral_data.convert.bag_paths import folder_bags
from openral_data.convert.kinds.bags import BagKind
from openral_data.formats.mcap.foreign import is_foreign_mcap
from openral_data.schemas.mapping import Mapping


class McapKind(BagKind):
    name = "mcap"
    summary = "MCAP of another profile than ROS 2 (Foxglove: protobuf, JSON, ROS 1 messages), or a folder of them"

    def open(self, path: Path) -> Path | None:
        if path.is_file():
            return path if is_foreign_mcap(path) else None
        bags = folder_bags(path)
        return path if bags and all(is_foreign_mcap(b) for b in bags) else None

    def default_mapping(self, handle: Path) -> Mapping:
        """The guessed mapping (`--print-mapping`'s), validated: nobody wrote start markers into these files."""
        from openral_data.convert.guess_mapping import guess_mapping

        return Mapping.model_validate(guess_mapping(handle).mapping)
