"""`openral-data upgrade OLD NEW`: a LeRobot v2.0/v2.1 dataset written as v3.0 by lerobot's own converter.

legacy (OLD's meta files and episode files, checked), columns (the per-frame index columns as lerobot writes
them, rewritten where OLD's differ), episode_stats (per-episode statistics OLD lacks, by
lerobot's `compute_episode_stats`), source (the fixed-up v2.1 copy lerobot's converter reads), run (the
converter's steps into a staging folder, published as NEW).
"""

from openral_data.upgrade.run import UpgradeResult, upgrade

__all__ = ["UpgradeResult", "upgrade"]
