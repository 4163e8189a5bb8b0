"""LeRobotDataset v3, the layout lerobot 0.6.1 loads, read and written without lerobot (pyarrow + PyAV).

Reading: `read_info`, `read_tasks` and `read_episodes` give a dataset's metadata, `summarize` a
`DatasetSummary`; `episode_frames` reads an episode's frames back (images decoded) and `episode_clip` cuts an
episode's packets out of a shared mp4 without re-encoding. `variants` reads the older v3 layouts lerobot still
loads (tasks as an unnamed pandas index, `channel` names, `video_info` blocks) the way every reader needs them.

Writing: `LeRobotV3Writer` (a `Sink`, configured by `WriterConfig` and `VideoSettings`) commits one episode at a
time, crash-safe; `commit_episode` takes an `EpisodeBuffer` whose videos are already made. `DatasetLock` keeps
one writer per dataset (`holder` names it) and `recover` brings a killed writer's dataset back to its last
committed episode. The writer's parts: `buffer` (an episode's columns, table and meta/episodes row), `joins`
(per-episode files joined into lerobot's rotated layout), `tasks_table` (tasks.parquet), `config`,
`commit_log`. Paths and chunk/file numbering are in `layout`. `warm_up` pays pyarrow's first-use
cost ahead of a recording.
"""

from openral_data.formats.lerobot_v3.buffer import EpisodeBuffer
from openral_data.formats.lerobot_v3.clip import episode_clip
from openral_data.formats.lerobot_v3.config import WriterConfig
from openral_data.formats.lerobot_v3.encoder import VideoSettings
from openral_data.formats.lerobot_v3.frames import episode_frames
from openral_data.formats.lerobot_v3.lock import DatasetLock, holder
from openral_data.formats.lerobot_v3.reader import DatasetSummary, read_episodes, read_info, read_tasks, summarize
from openral_data.formats.lerobot_v3.recovery import recover
from openral_data.formats.lerobot_v3.writer import LeRobotV3Writer, warm_up

__all__ = [
    "DatasetLock",
    "DatasetSummary",
    "EpisodeBuffer",
    "LeRobotV3Writer",
    "VideoSettings",
    "WriterConfig",
    "episode_clip",
    "episode_frames",
    "holder",
    "read_episodes",
    "read_info",
    "read_tasks",
    "recover",
    "summarize",
    "warm_up",
]
