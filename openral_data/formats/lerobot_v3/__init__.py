"""LeRobotDataset v3: writer (pyarrow + PyAV) and a light reader."""

from openral_data.formats.lerobot_v3.reader import DatasetSummary, summarize
from openral_data.formats.lerobot_v3.video import VideoSettings
from openral_data.formats.lerobot_v3.writer import LeRobotV3Writer, WriterConfig

__all__ = ["DatasetSummary", "LeRobotV3Writer", "VideoSettings", "WriterConfig", "summarize"]
