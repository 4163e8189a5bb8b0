"""LeRobot v2.0 / v2.1 (lerobot 0.x) read in place, read-only, in the shapes the v3 readers take.

A v2.x dataset keeps one data parquet per episode (``data/chunk-{episode_chunk:03d}/episode_{episode_index:06d}
.parquet``), one mp4 per episode and camera starting at 0 s, and its episodes and tasks as JSON lines
(``meta/episodes.jsonl``, ``meta/tasks.jsonl``; v2.1 adds ``meta/episodes_stats.jsonl``, v2.0 has only
``meta/stats.json``). `version` tells a v2.x info.json; `as_v3_info` gives it v3 path templates whose
(chunk_index, file_index) are an episode's (chunk, index), so `lerobot_v3.layout.template_path` finds an
episode's own files; `read_tasks` and `read_episodes` give the tasks in task_index order and an episodes table
with v3's columns (dataset_from_index/to_index, data/..., videos/<key>/... from 0 to length / fps). Writing a v2
dataset is not offered: `openral-data upgrade OLD NEW` writes v3. Every path stays inside the dataset
(`template_path`), every JSON Lines file is read bounded (`read_jsonl`). The file names are in `_layout`.
"""

from openral_data.formats.lerobot_v2._jsonl import read_jsonl
from openral_data.formats.lerobot_v2._layout import (
    EPISODES_PATH,
    EPISODES_STATS_PATH,
    STATS_PATH,
    TASKS_PATH,
    VERSIONS,
    version,
)
from openral_data.formats.lerobot_v2._reader import as_v3_info, data_files, read_episodes, read_raw_info, read_tasks

__all__ = [
    "EPISODES_PATH",
    "EPISODES_STATS_PATH",
    "STATS_PATH",
    "TASKS_PATH",
    "VERSIONS",
    "as_v3_info",
    "data_files",
    "read_episodes",
    "read_jsonl",
    "read_raw_info",
    "read_tasks",
    "version",
]
