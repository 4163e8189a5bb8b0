"""ROS 2 / MCAP: a sink writing one rosbag2 bag per episode (rosbags, CDR, standard message types)."""

from openral_data.formats.mcap.messages import IMAGE_FORMATS, ImageFormat
from openral_data.formats.mcap.writer import McapConfig, McapSink, finished_bags

__all__ = ["IMAGE_FORMATS", "ImageFormat", "McapConfig", "McapSink", "finished_bags"]
