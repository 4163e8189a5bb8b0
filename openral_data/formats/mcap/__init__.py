"""ROS 2 / MCAP: one rosbag2 bag per episode (rosbags, CDR, standard message types; topics in `messages`).

Writing: `McapSink` (a `Sink`, configured by `McapConfig`; chunks compressed as one of `MCAP_COMPRESSIONS`;
camera images stored as an `ImageFormat`, one of `IMAGE_FORMATS`; text from a user becomes one through
`parse_compression` / `parse_image_format`, the only places that check it); beside a LeRobot dataset the bags go
under `MCAP_SUBDIR` (`bags_dir`, refused if a symlink leads it out). Reading: `finished_bags` lists a folder's
complete episode bags (never the one in flight) and `decode_image` turns a camera message back into pixels.
"""

from openral_data.formats.mcap.messages import IMAGE_FORMATS, ImageFormat, decode_image, parse_image_format
from openral_data.formats.mcap.writer import (
    MCAP_COMPRESSIONS,
    MCAP_SUBDIR,
    McapCompression,
    McapConfig,
    McapSink,
    bags_dir,
    finished_bags,
    parse_compression,
)

__all__ = [
    "IMAGE_FORMATS",
    "MCAP_COMPRESSIONS",
    "MCAP_SUBDIR",
    "ImageFormat",
    "McapCompression",
    "McapConfig",
    "McapSink",
    "bags_dir",
    "decode_image",
    "finished_bags",
    "parse_compression",
    "parse_image_format",
]
