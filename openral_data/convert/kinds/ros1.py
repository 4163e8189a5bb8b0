"""ROS 1 bags: a `.bag` file, or a folder whose bags are all `.bag` files (read by rosbags, Noetic types)."""

from __future__ import annotations

from pathlib import Path

from openral_data.convert.bag_paths import folder_bags
from openral_data.convert.kinds.bags import BagKind


class Ros1Kind(BagKind):
    name = "ros1-bag"
    summary = "ROS 1 bags: a .bag file or a folder of them"

    def open(self, path: Path) -> Path | None:
        if path.is_file():
            return path if path.suffix == ".bag" else None
        bags = folder_bags(path)
        return path if bags and all(b.is_file() and b.suffix == ".bag" for b in bags) else None
