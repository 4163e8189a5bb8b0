"""Write episodes taken from existing datasets into a new one through our LeRobot v3 writer.

Each episode goes through the writer's normal commit (data rows re-indexed, episodes metadata, tasks, stats,
info.json), so the result follows every rule the writer follows. Video is never re-encoded: the episode's
packets are cut out of the source mp4 (`viz.clip.episode_clip`) and handed to the writer as the episode's own
file, which the writer joins into size-rotated files by remuxing, as it does while recording.

Statistics: numeric features are recomputed exactly from the rows. Camera statistics come from the source's
per-episode statistics; the dataset level merges them as lerobot's aggregation does (exact min, max, mean and
std; quantiles are frame-weighted means of the episodes' quantiles), because the pixel histograms they were
computed from are not stored.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from openral_data.edit.source import EpisodeData
from openral_data.sinks.base import DatasetSchema, EpisodeRecord, EpisodeStart
from openral_data.sinks.lerobot_v3 import atomic, layout
from openral_data.sinks.lerobot_v3.stats import ImageStatsAccumulator, Stats, merge_numeric
from openral_data.sinks.lerobot_v3.video import EncodedEpisode
from openral_data.sinks.lerobot_v3.writer import LeRobotV3Writer, WriterConfig, _EpisodeBuffer


class MergedImageStats(ImageStatsAccumulator):
    """Image statistics known only as per-episode summaries, merged count-weighted."""

    def __init__(self, stats: Stats | None = None) -> None:
        super().__init__()
        self._stats = stats

    def add(self, frame: Any) -> None:
        raise TypeError("MergedImageStats holds summaries, not frames")

    def merge(self, other: ImageStatsAccumulator) -> None:
        if not isinstance(other, MergedImageStats) or other._stats is None:
            raise TypeError("only summaries can be merged into MergedImageStats")
        self._stats = merge_numeric(self._stats, other._stats)
        self.frames += int(other._stats["count"][0])

    def stats(self) -> Stats:
        if self._stats is None:
            raise ValueError("no episode statistics merged")
        return self._stats


class EpisodeAssembler(LeRobotV3Writer):
    """A LeRobot v3 writer fed with whole episodes (`add`) instead of frames."""

    def __init__(self, root: Path, schema: DatasetSchema, config: WriterConfig, provenance: dict[str, Any]) -> None:
        super().__init__(root, schema, config)
        self._image_stats = {name: MergedImageStats() for name in schema.cameras}
        meta = json.loads((root / layout.OPENRAL_PATH).read_text())
        meta["edit"] = provenance
        atomic.write_bytes(root / layout.OPENRAL_PATH, json.dumps(meta, indent=2).encode(), config.durable)

    def add(self, episode: EpisodeData) -> EpisodeRecord:
        buf = _EpisodeBuffer(EpisodeStart(episode.seed, episode.initial_state))
        buf.states = list(episode.states)
        buf.actions = list(episode.actions)
        buf.rewards = list(episode.rewards)
        buf.dones = list(episode.dones)
        buf.successes = list(episode.successes)
        buf.task_indices = [self.tasks.setdefault(t, len(self.tasks)) for t in episode.tasks]
        encoded: dict[str, EncodedEpisode] = {}
        try:
            for name in self.schema.cameras:
                path = self._pending_video(name)
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_bytes(episode.videos[name])
                encoded[name] = EncodedEpisode(path, episode.length, MergedImageStats(episode.image_stats[name]))
            batch = self._batch = atomic.Batch(self.config.durable)
            try:
                record = self._commit_episode(buf, episode.length, episode.success, encoded)
                batch.commit()
            finally:
                self._batch = None
                batch.discard()
        except BaseException:
            for enc in encoded.values():
                enc.path.unlink(missing_ok=True)
            raise
        self._maybe_rotate_episodes_file()
        return record
