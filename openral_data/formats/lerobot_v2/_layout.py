"""The file layout of LeRobot v2.0/v2.1 (lerobot 0.x): one data parquet and one mp4 per camera per episode, the
episodes and tasks as JSON lines; the names are lerobot's own (its ``LEGACY_*`` constants and v2 templates)."""

from __future__ import annotations

from typing import Any

from openral_data.formats.lerobot_v3.reader import LEGACY_VERSIONS

VERSIONS = LEGACY_VERSIONS  # the versions this package reads (the v3 reader refuses them)

EPISODES_PATH = "meta/episodes.jsonl"
TASKS_PATH = "meta/tasks.jsonl"
EPISODES_STATS_PATH = "meta/episodes_stats.jsonl"  # v2.1: per-episode stats
STATS_PATH = "meta/stats.json"  # v2.0: the dataset's stats
DATA_PATH = "data/chunk-{episode_chunk:03d}/episode_{episode_index:06d}.parquet"
VIDEO_PATH = "videos/chunk-{episode_chunk:03d}/{video_key}/episode_{episode_index:06d}.mp4"
DEFAULT_CHUNKS_SIZE = 1000
# a v2 template's fields as the v3 ones `lerobot_v3.layout.template_path` formats: (chunk, file) = (episode chunk,
# episode index), so every reader of v3 paths finds an episode's own file
_AS_V3 = {"{episode_chunk": "{chunk_index", "{episode_index": "{file_index"}


def version(info: dict[str, Any]) -> str | None:
    """info.json's ``codebase_version`` if it is one this package reads (v2.0, v2.1), else None."""
    value = info.get("codebase_version")
    return value if value in VERSIONS else None


def as_v3_template(template: Any) -> Any:
    """A v2 ``data_path``/``video_path`` template with v3's field names (anything else is returned as it is, for
    `template_path` to refuse)."""
    if not isinstance(template, str):
        return template
    for old, new in _AS_V3.items():
        template = template.replace(old, new)
    return template


def chunk_of(episode: int, info: dict[str, Any]) -> int:
    """The chunk lerobot 0.x put episode `episode` in (``episode_index // chunks_size``)."""
    return episode // int(info.get("chunks_size") or DEFAULT_CHUNKS_SIZE)
