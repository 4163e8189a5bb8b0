"""LeRobot v3 -> ROS 2 MCAP: replay a dataset's episodes (all or selected) through our MCAP sink.

Frames are read one episode at a time: the numeric columns of that episode from its data parquet, the
images decoded with PyAV from each camera's mp4 starting at the episode's ``from_timestamp``; a depth video
(``is_depth_map``) becomes a 16UC1 Image topic (millimetres, as lerobot's loader returns them) and a camera's
``info.camera_info`` a CameraInfo topic. Works on any
LeRobot v3 dataset (ours or lerobot's) and on LeRobot v2.0/v2.1 ones (opened by `formats.dataset.open_lerobot`);
our extra episode columns (seed, success, initial state, episode info: who drove) are kept, and so are an
intervention session's per-frame proposal and flag (`openral.policy_action`, `openral.intervention`).
The bags are written into a hidden staging folder beside DST, renamed to DST once every bag is finished.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Literal

from openral_data.columns import INTERVENTION, POLICY_ACTION
from openral_data.convert.export_source import ExportSource, not_carried, read_export_source
from openral_data.formats.jsonfile import parse_field
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.features import dim_names
from openral_data.formats.lerobot_v3.images import ENVIRONMENT_STATE
from openral_data.formats.lerobot_v3.masks import MASK_IDS, is_mask
from openral_data.formats.lerobot_v3.provenance import Origin
from openral_data.formats.lerobot_v3.success import episode_successes
from openral_data.formats.lerobot_v3.variants import camera_layout, feature_info, is_depth
from openral_data.formats.mcap import McapConfig, McapSink
from openral_data.formats.staging import Staging, check_new_output
from openral_data.types import CameraShape, DatasetSchema, EpisodeRecord, EpisodeStart, FrameColumn

ProgressFn = Callable[[int, int], None]  # (frames exported, frames in total)
_QUANTIZER = ("video.depth_min", "video.depth_max", "video.shift", "video.use_log")


@dataclass
class ExportSummary:
    src: Path
    dst: Path
    episodes: list[EpisodeRecord] = field(default_factory=list)
    frames: int = 0
    seconds: float = 0.0
    skipped_features: list[str] = field(default_factory=list)
    format: str = "mcap"  # what was written: mcap, rlds or robomimic

    @property
    def fps(self) -> float:
        return self.frames / self.seconds if self.seconds > 0 else 0.0

    def to_json(self) -> dict[str, object]:
        """The fields of `convert --json` (`export --json`) for LeRobot -> MCAP (RLDS, robomimic), in
        docs/scripting.md's order."""
        return {
            "direction": f"lerobot-to-{self.format}",
            "source": str(self.src),
            "out": str(self.dst),
            "episodes": len(self.episodes),
            "frames": self.frames,
            "seconds": self.seconds,
            "frames_per_s": self.fps,
            "not_exported": list(self.skipped_features),
            "episode_list": [asdict(e) for e in self.episodes],
        }


def is_lerobot_dataset(path: Path) -> bool:
    return (path / layout.INFO_PATH).is_file()


def _camera_shape(feature: dict[str, Any]) -> CameraShape:
    """A camera of the dataset as the MCAP sink takes it: a depth video (`is_depth_map`) as 16UC1 millimetres
    with its quantizer settings, a segmentation mask as mono16 ids with their names, and the intrinsics
    (`info.camera_info`) when the feature has them."""
    info = feature_info(feature)  # a legacy `video_info` block too
    mask = is_mask(feature)
    keep = {
        k: v
        for k, v in info.items()
        if k == "camera_info" or (is_depth(feature) and k in _QUANTIZER) or (mask and k == MASK_IDS)
    }
    depth_unit: Literal["mm"] | None = "mm" if is_depth(feature) else None
    shape = camera_layout(feature)["shape"]  # height, width, channels (also of a channel-first feature)
    return CameraShape(int(shape[0]), int(shape[1]), depth_unit, keep, segmentation=mask)


def export_mcap(
    src: Path,
    dst: Path,
    *,
    episodes: str | None = None,
    config: McapConfig | None = None,
    progress: ProgressFn | None = None,
) -> ExportSummary:
    """Write episodes `episodes` (default: all) of the dataset at `src` as one MCAP bag each into the new folder
    `dst`: read the source, build the bags' schema, write every chosen episode, publish DST."""
    source = read_export_source(src)
    chosen = source.choose(episodes, "convert to MCAP")  # v2.x: its own numbers
    successes = episode_successes(src, source.episodes)  # the sink drops them if the schema has no success
    schema = _schema(source)
    extras = {c.key for c in schema.frame_columns}
    summary = ExportSummary(src=src, dst=dst, skipped_features=not_carried(source, extras))
    total = sum(int(source.rows[e]["length"]) for e in chosen)
    check_new_output(dst, "DST")
    staged = Staging(dst, "openral-data convert")  # DST appears with every bag or not at all
    with staged as staging:
        sink = McapSink(staging, schema, config)
        t0 = time.perf_counter()
        try:
            for e in chosen:
                row = source.rows[e]
                number = int(row["episode_index"])  # the source's own (v2.x: gaps allowed), kept by the bag
                sink.begin_episode(
                    EpisodeStart(
                        seed=int(row.get("openral.seed") or 0),
                        initial_state=parse_field(
                            row.get("openral.initial_state") or "{}", f"{src}: episode {number}: openral.initial_state"
                        ),
                    ),
                    index=number,
                )
                for frame in source.frames(row, schema.frame_columns):
                    sink.add_frame(frame)
                    summary.frames += 1
                    if progress is not None:
                        progress(summary.frames, total)
                info = row.get("openral.episode_info")  # who drove it: kept in the bag's end marker
                if info is not None:
                    sink.annotate_episode(parse_field(info, f"{src}: episode {number}: openral.episode_info"))
                summary.episodes.append(sink.end_episode(successes.get(number)))
        finally:
            sink.close()
        summary.seconds = time.perf_counter() - t0
        staged.publish("DST")
    return summary


def _schema(source: ExportSource) -> DatasetSchema:
    """The bags' schema: the dataset's state, action, cameras and outcome columns, its origin in the metadata."""
    info, features = source.info, source.features
    return DatasetSchema(
        fps=int(info["fps"]),
        state_names=tuple(dim_names(features["observation.state"], "observation.state")),
        action_names=tuple(dim_names(features["action"], "action")),
        cameras={n: _camera_shape(f) for n, f in source.cams.items()},
        robot_type=str(info.get("robot_type") or "unknown"),
        metadata=Origin(exported_from=str(source.path)).to_json(),
        has_reward="next.reward" in features,
        has_success="next.success" in features,
        environment_state_names=(
            tuple(dim_names(features[ENVIRONMENT_STATE], ENVIRONMENT_STATE)) if ENVIRONMENT_STATE in features else ()
        ),
        frame_columns=_frame_columns(features),
    )


def _frame_columns(features: dict[str, Any]) -> tuple[FrameColumn, ...]:
    """An intervention session's per-frame columns the dataset has (the policy's proposal, a float32 vector with
    the action's names; the flag, a bool of shape [1]): the bags carry them as topics of their own."""
    out = []
    if POLICY_ACTION in features and features[POLICY_ACTION].get("dtype") == "float32":
        out.append(FrameColumn(POLICY_ACTION, "float32", tuple(dim_names(features[POLICY_ACTION], POLICY_ACTION))))
    if INTERVENTION in features and features[INTERVENTION].get("dtype") == "bool":
        out.append(FrameColumn(INTERVENTION, "bool"))
    return tuple(out)
