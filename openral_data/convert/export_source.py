"""What every export of a LeRobot dataset (LeRobot v3 or v2.x read in place -> MCAP, RLDS, robomimic) reads of it
before writing: info.json checked (a state, an action, cameras that are videos or images), its cameras, its
episodes in episode-index order, its tasks, each episode's split (info.json's `splits`), the episodes chosen by
`--episodes`, and one episode's frames (numbers from its parquet, pictures decoded)."""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from openral_data.episodes import select_numbered
from openral_data.errors import DatasetError
from openral_data.formats.dataset import open_lerobot
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.features import IMAGE_PREFIX, camera_keys
from openral_data.formats.lerobot_v3.frames import episode_frames
from openral_data.formats.lerobot_v3.images import ENVIRONMENT_STATE
from openral_data.formats.lerobot_v3.missing import missing_files
from openral_data.formats.lerobot_v3.splits import range_splits

if TYPE_CHECKING:
    import pyarrow as pa

    from openral_data.types import EpisodeRecord, Frame, FrameColumn


@dataclass(frozen=True)
class ExportSource:
    """The dataset at `path`: info.json, its cameras (name -> feature, `keys` name -> feature key), its
    episodes (the table and its rows in episode-index order) and tasks."""

    path: Path
    info: dict[str, Any]
    cams: dict[str, dict[str, Any]]
    keys: dict[str, str]
    episodes: pa.Table
    rows: list[dict[str, Any]]
    tasks: list[str]

    @property
    def features(self) -> dict[str, Any]:
        features: dict[str, Any] = self.info["features"]
        return features

    @property
    def fps(self) -> int:
        return int(self.info["fps"])

    def choose(self, episodes: str | None, what: str) -> list[int]:
        """The positions in `rows` of the episodes `--episodes` names (all by default, the dataset's own numbers),
        their video files checked present (`what`: the command, in the one-line error)."""
        chosen = select_numbered(episodes, [int(r["episode_index"]) for r in self.rows])
        videos = [k for k in self.keys.values() if self.features[k].get("dtype") == "video"]
        missing_files(self.path, self.info, [self.rows[e] for e in chosen], videos).need(None, videos, what)
        return chosen

    def split_of(self, row: dict[str, Any]) -> str:
        """The split of the episode `row` (info.json's `splits`; an episode in none is `train`'s)."""
        splits = range_splits(self.info.get("splits"), f"{self.path / layout.INFO_PATH}: splits")
        number = int(row["episode_index"])
        return next((name for name, span in splits.items() if number in span), "train")

    def frames(self, row: dict[str, Any], columns: Sequence[FrameColumn] = ()) -> Iterator[Frame]:
        """Episode `row` frame by frame, its pictures decoded (cameras in `cams` order)."""
        return episode_frames(self.path, self.info, row, self.tasks, list(self.cams), columns)


@dataclass
class Written[J]:
    """What one job of an export (an RLDS shard, a robomimic part) wrote: its episodes, frames and bytes, and
    when it finished (a parallel run's results come back in that order)."""

    job: J
    episodes: list[EpisodeRecord] = field(default_factory=list)
    frames: int = 0
    bytes: int = 0
    finished_at: float = 0.0


def not_carried(source: ExportSource, also: set[str] | frozenset[str] = frozenset()) -> list[str]:
    """Features of the dataset that an export does not carry: all but the state, action, cameras, outcome
    columns, environment state and indices (and `also`: the export's own extras)."""
    known = {"observation.state", "action", "timestamp", "frame_index", "episode_index", "index", "task_index"}
    known |= {"next.reward", "next.done", "next.success", ENVIRONMENT_STATE} | set(source.keys.values()) | also
    return sorted(set(source.features) - known)


def read_export_source(src: Path) -> ExportSource:
    """info.json checked for what an export needs (a state, an action, cameras that are videos or images), then
    the episodes table."""
    dataset = open_lerobot(src)  # v3, or v2.x read in place
    info = dataset.info
    features: dict[str, Any] = info["features"]
    for key in ("observation.state", "action"):
        if key not in features:
            raise DatasetError(f"{src / layout.INFO_PATH}: features: no {key!r}; cannot export", code="dataset.invalid")
    keys = camera_keys(features)  # every video or image feature, under its camera name
    odd = [k for k, f in features.items() if k.startswith(IMAGE_PREFIX) and k not in keys.values()]
    if odd:
        raise DatasetError(
            f"{src}: cameras {odd} are neither videos nor images; cannot export them", code="dataset.unsupported"
        )
    cams = {name: features[key] for name, key in keys.items()}
    ep_table = dataset.episodes()
    rows = sorted(ep_table.to_pylist(), key=lambda r: int(r["episode_index"]))
    return ExportSource(src, info, cams, keys, ep_table, rows, dataset.tasks())
