"""LeRobotDataset v3, the layout lerobot 0.6.1 loads, read and written without lerobot (pyarrow + PyAV).

Reading: `read_info`, `read_tasks` and `read_episodes` give a dataset's metadata, `summarize` a
`DatasetSummary`; `episode_frames` reads an episode's frames back (images decoded) and `episode_clip` cuts an
episode's packets out of a shared mp4 without re-encoding. `variants` reads the older v3 layouts lerobot still
loads (tasks as an unnamed pandas index, `channel` names, `video_info` blocks) the way every reader needs them.

Writing: `LeRobotV3Writer` (a `Sink`, configured by `WriterConfig` and `VideoSettings`) commits one episode at a
time, crash-safe; `commit_episode` takes an `EpisodeBuffer` whose videos are already made. `DatasetLock` keeps
one writer per dataset (`holder` names it) and `recover` brings a killed writer's dataset back to its last
committed episode. The writer's parts: `buffer` (an episode's columns, table and meta/episodes row; `warm_up`
pays pyarrow's first-use cost ahead of a recording), `joins` (per-episode files joined into lerobot's rotated
layout), `tasks_table` (tasks.parquet), `config`, `commit_log`, `committer` (episodes committed behind a
real-time recording). Paths and chunk/file numbering are in `layout`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from openral_data.lazy import lazy_names

# name -> the module that defines it: imported on first use, so reading a dataset's metadata (`info`) does not
# import the writer, PyAV and the encoders
_API: dict[str, str] = {
    "DatasetLock": "openral_data.formats.lerobot_v3.lock",
    "DatasetSummary": "openral_data.formats.lerobot_v3.reader",
    "EpisodeBuffer": "openral_data.formats.lerobot_v3.buffer",
    "LeRobotV3Writer": "openral_data.formats.lerobot_v3.writer",
    "VideoSettings": "openral_data.formats.lerobot_v3.encoder",
    "WriterConfig": "openral_data.formats.lerobot_v3.config",
    "episode_clip": "openral_data.formats.lerobot_v3.clip",
    "episode_frames": "openral_data.formats.lerobot_v3.frames",
    "holder": "openral_data.formats.lerobot_v3.lock",
    "read_episodes": "openral_data.formats.lerobot_v3.reader",
    "read_info": "openral_data.formats.lerobot_v3.reader",
    "read_tasks": "openral_data.formats.lerobot_v3.reader",
    "recover": "openral_data.formats.lerobot_v3.recovery",
    "summarize": "openral_data.formats.lerobot_v3.reader",
    "warm_up": "openral_data.formats.lerobot_v3.buffer",
}

if TYPE_CHECKING:
    from openral_data.formats.lerobot_v3.buffer import EpisodeBuffer, warm_up
    from openral_data.formats.lerobot_v3.clip import episode_clip
    from openral_data.formats.lerobot_v3.config import WriterConfig
    from openral_data.formats.lerobot_v3.encoder import VideoSettings
    from openral_data.formats.lerobot_v3.frames import episode_frames
    from openral_data.formats.lerobot_v3.lock import DatasetLock, holder
    from openral_data.formats.lerobot_v3.reader import DatasetSummary, read_episodes, read_info, read_tasks, summarize
    from openral_data.formats.lerobot_v3.recovery import recover
    from openral_data.formats.lerobot_v3.writer import LeRobotV3Writer

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


__getattr__ = lazy_names(__name__, _API)
