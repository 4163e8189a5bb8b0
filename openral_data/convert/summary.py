"""What a bags -> LeRobot conversion reports (`convert --json`): per run and per mapped topic."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from pathlib import Path

from openral_data.schemas.mapping import Mapping
from openral_data.types import EpisodeRecord


@dataclass
class TopicReport:
    topic: str
    msgtype: str
    messages: int = 0
    used: int = 0  # samples that went into at least one frame
    unused: int = 0  # superseded by a later/nearer sample, or outside every frame's window
    unfillable_frames: int = 0  # grid frames this topic had no sample for within max_staleness


@dataclass
class ConvertSummary:
    src: Path
    dst: Path
    bags: int = 0
    episodes: list[EpisodeRecord] = field(default_factory=list)
    frames: int = 0
    seconds: float = 0.0
    topics: dict[str, TopicReport] = field(default_factory=dict)
    skipped_topics: dict[str, int] = field(default_factory=dict)  # unmapped topic -> messages not read
    unfillable_frames: int = 0
    splits: int = 0  # extra episodes started because unfillable frames interrupted a source episode
    empty_segments: int = 0  # source episodes in which no frame could be filled
    late_messages: int = 0  # align.clock header: stamps further than align.reorder behind the newest one read
    header_stamps: dict[str, int] = field(default_factory=dict)  # align.clock header: topic -> stamped messages
    zero_stamps: dict[str, int] = field(default_factory=dict)  # ... of them with header.stamp 0
    trailing_bytes: dict[str, int] = field(default_factory=dict)  # ROS 1: topic -> decoded messages with bytes
    #   after their last field (ignored, as ROS 1's own reader does)
    source_episodes: int = 0  # source episodes seen (boundaries by the mapping's episodes.split)
    source_kind: str | None = None  # an array source's layout (robomimic, aloha, ...); None: bags

    @property
    def fps(self) -> float:
        return self.frames / self.seconds if self.seconds > 0 else 0.0

    def to_json(self, mapping: Mapping, workers: int = 1, executor: str | None = None) -> dict[str, object]:
        """The fields of `convert --json` for bags -> LeRobot (made with `mapping`; `executor` None: one
        process), in docs/scripting.md's order."""
        return {
            "direction": "bags-to-lerobot" if self.source_kind is None else "arrays-to-lerobot",
            "layout": self.source_kind,
            "source": str(self.src),
            "out": str(self.dst),
            "bags": self.bags,
            "episodes": len(self.episodes),
            "frames": self.frames,
            "fps": mapping.fps,
            "seconds": self.seconds,
            "frames_per_s": self.fps,
            "workers": workers,
            "executor": executor,
            "align_method": mapping.align.method,
            "align_clock": mapping.align.clock,
            "max_staleness_s": mapping.align.max_staleness,
            "topics": {t: asdict(r) for t, r in self.topics.items()},
            "unfillable_frames": self.unfillable_frames,
            "splits": self.splits,
            "empty_segments": self.empty_segments,
            "late_messages": self.late_messages if mapping.align.clock == "header" else None,
            "reward_topic": mapping.reward.topic if mapping.reward is not None else None,
            "success_topic": mapping.success.topic if mapping.success is not None else None,
            "success_markers": mapping.success is not None and mapping.success.marker,
            "skipped_topics": dict(sorted(self.skipped_topics.items())),
            "trailing_bytes": dict(sorted(self.trailing_bytes.items())),
            "episode_list": [asdict(e) for e in self.episodes],
        }
