"""MCAP of another profile than ROS 2 (Foxglove's SDKs, the `mcap` library): a ``.mcap`` file of protobuf, JSON
or ROS 1 messages, or a folder of them (`formats.mcap.foreign`). Converted with no mapping written from its
guessed one (`--print-mapping` prints it): Foxglove's well-known schemas and joint-like numbers are mapped as
ROS's types are."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from openral_data.convert.bag_paths import folder_bags
from openral_data.convert.kinds.bags import BagKind

if TYPE_CHECKING:
    from openral_data.schemas.mapping import Mapping


class McapKind(BagKind):
    name = "mcap"
    summary = "MCAP of another profile than ROS 2 (Foxglove: protobuf, JSON, ROS 1 messages), or a folder of them"

    def open(self, path: Path) -> Path | None:
        bags = [path] if path.is_file() else folder_bags(path)
        return path if bags and all(_foreign(b) for b in bags) else None

    def default_mapping(self, handle: Path) -> Mapping:
        """The guessed mapping (`--print-mapping`'s), validated: nobody wrote start markers into these files."""
        from openral_data.convert.guess_mapping import guess_mapping
        from openral_data.schemas.mapping import Mapping

        return Mapping.model_validate(guess_mapping(handle).mapping)


def _foreign(path: Path) -> bool:
    """An `.mcap` file of another profile than ros2 (its header read; mcap's reader imported only for `.mcap`)."""
    if not (path.suffix.lower() == ".mcap" and path.is_file()):
        return False
    from openral_data.formats.mcap.foreign import is_foreign_mcap

    return is_foreign_mcap(path)
