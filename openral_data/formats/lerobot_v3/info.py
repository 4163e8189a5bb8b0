"""The shape of `meta/info.json` every reader relies on, checked once when it is read: an untrusted file with a
wrong type (``fps: 0``, ``features`` as a list, a count as text) is one error naming the file and the key."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from openral_data.errors import DatasetError
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.splits import splits_of
from openral_data.types import DatasetSchema

if TYPE_CHECKING:  # the writer's settings import PyAV, which `info` does not need
    from openral_data.formats.lerobot_v3.config import WriterConfig

MAX_FPS = 1000  # as a scene or mapping may declare
MAX_FEATURES = 10_000  # ours have tens; a million would make every reader (and lerobot) crawl
_COUNTS = ("total_episodes", "total_frames", "total_tasks")
_TEXTS = ("codebase_version", "robot_type", "data_path", "video_path")


def _bad(path: Path, key: str, what: str, value: Any) -> DatasetError:
    shown = repr(value)
    shown = shown if len(shown) <= 60 else shown[:57] + "..."
    return DatasetError(f"{path}: {key}: {what}, got {shown}", code="dataset.invalid")


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def check_info(info: Any, path: Path) -> dict[str, Any]:
    """`info` (parsed from `path`) if it has the types readers use; else a `DatasetError` naming the key."""
    if not isinstance(info, dict):
        raise DatasetError(f"{path}: expected a JSON object, got {type(info).__name__}", code="dataset.invalid")
    if "fps" not in info:
        raise DatasetError(f"{path}: fps: missing", code="dataset.invalid")
    fps = info["fps"]
    if not _is_int(fps) or not 1 <= fps <= MAX_FPS:
        raise _bad(path, "fps", f"must be an integer in 1..{MAX_FPS}", fps)
    features = info.get("features")
    if not isinstance(features, dict):
        raise _bad(path, "features", "must be an object of feature name -> description", features)
    if len(features) > MAX_FEATURES:
        raise DatasetError(f"{path}: features: more than {MAX_FEATURES} features", code="dataset.invalid")
    for key, feature in features.items():
        if not isinstance(feature, dict):
            raise _bad(path, f"features.{key}", "must be an object (dtype, shape, names)", feature)
    for key in _COUNTS:
        value = info.get(key)
        if value is not None and not (_is_int(value) and value >= 0):
            raise _bad(path, key, "must be an integer >= 0", value)
    chunks = info.get("chunks_size")
    if chunks is not None and not (_is_int(chunks) and chunks >= 1):
        raise _bad(path, "chunks_size", "must be an integer >= 1", chunks)
    for key in _TEXTS:
        value = info.get(key)
        if value is not None and not isinstance(value, str):
            raise _bad(path, key, "must be text", value)
    return info


def dataset_info(
    schema: DatasetSchema,
    config: WriterConfig,
    features: dict[str, dict[str, Any]],
    totals: tuple[int, int, int],
    videos: bool,
    rows: list[dict[str, Any]],
) -> dict[str, Any]:
    """The meta/info.json the writer writes: `totals` are its episodes, frames and tasks, `rows` its episode rows
    (their splits), `videos` whether it has video features."""
    return {
        "codebase_version": layout.CODEBASE_VERSION,
        "fps": schema.fps,
        "features": features,
        "total_episodes": totals[0],
        "total_frames": totals[1],
        "total_tasks": totals[2],
        "chunks_size": config.chunks_size,
        "data_files_size_in_mb": config.data_files_size_in_mb,
        "video_files_size_in_mb": config.video_files_size_in_mb,
        "data_path": layout.DATA_PATH,
        "video_path": layout.VIDEO_PATH if videos else None,
        "robot_type": schema.robot_type,
        "splits": splits_of(rows),
    }
