"""ROS 2 / MCAP: one rosbag2 bag per episode (rosbags, CDR, standard message types; topics in `messages`).

Writing: `McapSink` (a `Sink`, configured by `McapConfig`; camera images stored as an `ImageFormat`, one of
`IMAGE_FORMATS`). Reading: `finished_bags` lists a folder's complete episode bags (never the one in flight)
and `decode_image` turns a camera message back into pixels.
"""

from openral_data.formats.mcap.messages import IMAGE_FORMATS, ImageFormat, decode_image
from openral_data.formats.mcap.writer import McapConfig, McapSink, finished_bags

__all__ = [
    "IMAGE_FORMATS",
    "ImageFormat",
    "McapConfig",
    "McapSink",
    "decode_image",
    "finished_bags",
]
