"""ROS 2 / MCAP: one rosbag2 bag per episode (rosbags, CDR, standard message types; topics in `messages`).

Writing: `McapSink` (a `Sink`, configured by `McapConfig`; chunks compressed as one of `MCAP_COMPRESSIONS`;
camera images stored as an `ImageFormat`, one of `IMAGE_FORMATS`); beside a LeRobot dataset the bags go under
`MCAP_SUBDIR`. Reading: `finished_bags` lists a folder's complete episode bags (never the one in flight) and
`decode_image` turns a camera message back into pixels.
"""

from openral_data.formats.mcap.messages import IMAGE_FORMATS, ImageFormat, decode_image
from openral_data.formats.mcap.writer import (
    MCAP_COMPRESSIONS,
    MCAP_SUBDIR,
    McapCompression,
    McapConfig,
    McapSink,
    check_compression,
    finished_bags,
)

__all__ = [
    "IMAGE_FORMATS",
    "MCAP_COMPRESSIONS",
    "MCAP_SUBDIR",
    "ImageFormat",
    "McapCompression",
    "McapConfig",
    "McapSink",
    "check_compression",
    "decode_image",
    "finished_bags",
]
