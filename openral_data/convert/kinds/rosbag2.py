"""rosbag2 and MCAP: a rosbag2 folder (`metadata.yaml` + sqlite3 or mcap storage), a plain `.mcap` file with
ros2msg schemas, or a folder of bags (any mix with ROS 1 `.bag` files, each read by its own reader)."""

from __future__ import annotations

from pathlib import Path

from openral_data.convert.bag_paths import is_bag_source
from openral_data.convert.kinds.bags import BagKind


class Rosbag2Kind(BagKind):
    name = "rosbag2"
    summary = "rosbag2 folders (sqlite3 or mcap storage), plain .mcap files, or a folder of bags"

    def open(self, path: Path) -> Path | None:
        return path if is_bag_source(path) else None
