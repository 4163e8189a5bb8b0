"""`WriterConfig`: how `LeRobotV3Writer` encodes videos and sizes, numbers and syncs its files."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.depth import DepthSettings
from openral_data.formats.lerobot_v3.encoder import VideoSettings
from openral_data.formats.lerobot_v3.spill import SpillBudget
from openral_data.types import CameraShape

MB = 1 << 20


@dataclass(frozen=True)
class WriterConfig:
    video: VideoSettings = field(default_factory=VideoSettings)
    depth: DepthSettings = field(default_factory=DepthSettings)  # the quantizer of depth cameras (lerobot's)
    data_files_size_in_mb: int = 100
    video_files_size_in_mb: int = 200
    chunks_size: int = layout.DEFAULT_CHUNKS_SIZE
    durable: bool = True
    queue_size: int = 16  # frames per camera waiting in memory for its encoder
    # beyond `queue_size`: spill frames to the dataset's staging area instead of making the producer wait (a
    # real-time recording, `record --hal`; video.py), and note each episode's spills and encoder lag (`capture`)
    spill: bool = False
    # the spilled bytes on disk at once, over all cameras (MB; None: half the dataset disk's free space when the
    # writer opens); a spill beyond it fails the episode in flight with `write.disk.spill` (spill.py)
    spill_limit_mb: float | None = None
    # commit each finished episode behind the recording, on a thread of its own, while the next one records (the
    # first episode is committed before the next starts); committer.py
    background: bool = False
    # committed episodes whose data and meta/episodes rows stay in files of their own (a commit then costs
    # O(that episode)) before they are joined into the run's first file; a data rotation and close() join too
    staged_episodes: int = 1000

    def __post_init__(self) -> None:
        if self.staged_episodes < 1:
            raise ValueError("staged_episodes must be at least 1")
        if self.spill_limit_mb is not None and self.spill_limit_mb < 0:
            raise ValueError("spill_limit_mb must not be negative")
        # a concrete encoder (`auto` probed once per process), checked against this FFmpeg before anything is written
        object.__setattr__(self, "video", self.video.resolve())

    def size_problem(self, shape: CameraShape) -> str | None:
        """Why a video camera of `shape` cannot be encoded (the codec's limits, or the depth quantizer's)."""
        if shape.depth_unit is None:
            return self.video.size_problem(shape.height, shape.width)
        return self.depth.size_problem(shape.height, shape.width)

    def spill_budget(self, root: Path) -> SpillBudget | None:
        """The spilled bytes' cap of a writer at `root` (`spill_limit_mb`), shared by its cameras; None: no spill."""
        return SpillBudget.for_root(root, self.spill_limit_mb) if self.spill else None

    @property
    def data_limit(self) -> int:
        """Bytes a data (and meta/episodes) file holds before the next one starts."""
        return self.data_files_size_in_mb * MB

    @property
    def video_limit(self) -> int:
        """Bytes a video file holds before the next one starts."""
        return self.video_files_size_in_mb * MB

    def settings_json(self) -> dict[str, Any]:
        """The settings meta/openral.json records (`config`): codec and file sizes; the encoder that ran and a
        pixel format or preset other than lerobot's default only when they are not the software default."""
        video = self.video
        return {
            "codec": video.feature_info(0, 0, 0)["video.codec"],
            "crf": video.crf,
            "g": video.g,
            **({"encoder": video.encoder} if video.hardware else {}),
            **({"pix_fmt": video.pix_fmt} if video.pix_fmt != "yuv420p" else {}),
            **({"preset": video.preset} if video.preset is not None else {}),
            "data_files_size_in_mb": self.data_files_size_in_mb,
            "video_files_size_in_mb": self.video_files_size_in_mb,
            "chunks_size": self.chunks_size,
        }
