"""On-disk formats: LeRobot v3 (`lerobot_v3`), ROS 2 MCAP (`mcap`), the replay/stats results layout (`results`)
and crash-safe file writes (`atomic`). Formats import only the shared types, errors and schemas below them."""
