"""Write episodes taken from existing datasets into a new one through our LeRobot v3 writer.

Each episode goes through the writer's normal commit (data rows re-indexed, episodes metadata, tasks, stats,
info.json), so the result follows every rule the writer follows. Video is never re-encoded: the episode's
packets are cut out of the source mp4 (`formats.lerobot_v3.clip.episode_clip`) and handed to the writer as the
episode's own file, which the writer joins into size-rotated files by remuxing, as it does while recording.

Statistics: numeric features are recomputed exactly from the rows. Camera statistics per episode are the
source's. At dataset level they are exact when the caller passes the pixel histograms of exactly the episodes
written (`record --workers` sums its workers' `.openral/image_hist.json`); otherwise (a subset of a dataset)
they are merged from the per-episode statistics as lerobot's aggregation does (exact min, max, mean and std;
quantiles are frame-weighted means of the episodes' quantiles), and no histogram file is left behind, so
`record --resume` refuses to continue such a dataset rather than continue wrong statistics.
"""

from __future__ import annotations

import contextlib
from dataclasses import replace
from pathlib import Path
from typing import Any

from openral_data.edit.source import EpisodeData
from openral_data.errors import DatasetError
from openral_data.formats import atomic
from openral_data.formats.jsonfile import read_json
from openral_data.formats.lerobot_v3 import EpisodeBuffer, LeRobotV3Writer, WriterConfig, layout
from openral_data.formats.lerobot_v3.provenance import EditRecord, Provenance
from openral_data.formats.lerobot_v3.stats import ImageStatsAccumulator, Stats, merge_numeric
from openral_data.formats.lerobot_v3.video import EncodedEpisode
from openral_data.types import DatasetSchema, EpisodeRecord, EpisodeStart


class MergedImageStats(ImageStatsAccumulator):
    """Image statistics known only as per-episode summaries, merged count-weighted (`summary`)."""

    def __init__(self, summary: Stats | None = None) -> None:
        super().__init__()
        self.summary = summary

    def add(self, frame: Any) -> None:
        raise TypeError("MergedImageStats holds summaries, not frames")

    def merge(self, other: ImageStatsAccumulator) -> None:
        if not isinstance(other, MergedImageStats) or other.summary is None:
            raise TypeError("only summaries can be merged into MergedImageStats")
        self.summary = merge_numeric(self.summary, other.summary)
        self.frames += int(other.summary["count"][0])

    def stats(self) -> Stats:
        if self.summary is None:
            raise ValueError("no episode statistics merged")
        return self.summary


class EpisodeAssembler:
    """A new LeRobot v3 dataset fed with whole episodes (`add`) instead of frames, through our writer."""

    def __init__(
        self,
        root: Path,
        schema: DatasetSchema,
        config: WriterConfig,
        provenance: EditRecord,
        image_hist: dict[str, ImageStatsAccumulator] | None = None,
        features: dict[str, dict[str, Any]] | None = None,
        column_hist: dict[str, ImageStatsAccumulator] | None = None,
    ) -> None:
        """`features`: the source's info.json features, written verbatim (see `LeRobotV3Writer`).
        `column_hist`: exact histograms of carried `dtype: image` features over the episodes written, read at
        `close()` for the dataset's statistics (else they are merged from the episodes' statistics)."""
        merged: dict[str, ImageStatsAccumulator] = {name: MergedImageStats() for name in schema.cameras}
        self.writer = LeRobotV3Writer(root, schema, config, image_stats=merged, features=features)
        self.root = root
        self.schema = schema
        self._exact_hist = image_hist
        self._column_hist = column_hist
        written = Provenance.from_json(read_json(root / layout.OPENRAL_PATH))
        atomic.write_bytes(root / layout.OPENRAL_PATH, replace(written, edit=provenance).dumps(), config.durable)

    @property
    def total_episodes(self) -> int:
        return self.writer.total_episodes

    @property
    def total_frames(self) -> int:
        return self.writer.total_frames

    def close(self) -> None:
        writer, exact = self.writer, self._exact_hist
        try:
            if exact is not None and writer.total_episodes and not writer.closed:
                frames = {name: acc.frames for name, acc in writer.image_stats.items()}
                if {name: acc.frames for name, acc in exact.items()} != frames:
                    raise DatasetError(
                        f"{self.root}: camera histograms do not cover exactly the episodes written",
                        code="dataset.invalid",
                    )
                writer.use_image_stats(exact)  # the final metadata write uses the exact histograms
            if self._column_hist is not None and writer.total_episodes and not writer.closed:
                writer.override_stats({key: acc.stats() for key, acc in self._column_hist.items()})
        finally:
            writer.close()
        if exact is None:
            # summaries cannot continue a histogram: leave none, so a resume refuses instead of going wrong
            (self.root / layout.IMAGE_HIST_PATH).unlink(missing_ok=True)

    def abort(self) -> None:
        """Stop after a failed copy: release the writer's encoders without checking or finishing anything (the
        output is being thrown away; a second error from it must not replace the one that stopped the copy)."""
        with contextlib.suppress(Exception):
            self.writer.close()

    def add(self, episode: EpisodeData) -> EpisodeRecord:
        writer = self.writer
        buf = EpisodeBuffer(
            EpisodeStart(episode.seed, episode.initial_state),
            states=list(episode.states),
            actions=list(episode.actions),
            rewards=list(episode.rewards),
            dones=list(episode.dones),
            successes=list(episode.successes),
            task_indices=[writer.task_index(t) for t in episode.tasks],
            columns=dict(episode.columns),
            column_stats=dict(episode.column_stats),
            info=episode.info,
        )
        encoded: dict[str, EncodedEpisode] = {}
        try:
            for name in self.schema.cameras:
                path = writer.pending_video(name)
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_bytes(episode.videos[name])
                encoded[name] = EncodedEpisode(path, episode.length, MergedImageStats(episode.image_stats[name]))
            return writer.commit_episode(buf, episode.success, encoded, journal=False)
        except BaseException:
            for enc in encoded.values():
                enc.path.unlink(missing_ok=True)
            raise
