"""`openral-data convert`: robot logs (ROS 1/2 bags, MCAP) -> LeRobot v3, and LeRobot v3 -> ROS 2 MCAP."""

from openral_data.convert.summary import ConvertSummary
from openral_data.convert.to_lerobot import convert_bags
from openral_data.convert.to_mcap import ExportSummary, export_mcap, is_lerobot_dataset

__all__ = ["ConvertSummary", "ExportSummary", "convert_bags", "export_mcap", "is_lerobot_dataset"]
