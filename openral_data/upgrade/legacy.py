"""A LeRobot v2.0/v2.1 dataset as `upgrade` reads it: its meta files checked, its episodes' files found.

`read_legacy(root)` reads `meta/info.json` and the JSON-lines files (`episodes.jsonl`, `tasks.jsonl` and, in
v2.1, `episodes_stats.jsonl`) the one bounded way (`lerobot_v2.read_jsonl`), and names every
episode's data file and video files by info.json's `data_path`/`video_path` templates, each kept inside the
root after symlinks (`paths.contained`) and a regular file. Anything wrong is one line naming the file and
field: not a dataset, a v3 dataset (``already v3.0``), a broken line, an episode whose files are missing.
Nothing here writes.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from openral_data.errors import DatasetError
from openral_data.formats import lerobot_v2
from openral_data.formats.jsonfile import read_json
from openral_data.paths import contained, from_template, regular_file, safe_name

INFO = "meta/info.json"
EPISODES = "meta/episodes.jsonl"
TASKS = "meta/tasks.jsonl"
EPISODES_STATS = "meta/episodes_stats.jsonl"
VERSIONS = ("v2.0", "v2.1")
# what lerobot 0.x wrote when a template is missing from info.json
DATA_TEMPLATE = "data/chunk-{episode_chunk:03d}/episode_{episode_index:06d}.parquet"
VIDEO_TEMPLATE = "videos/chunk-{episode_chunk:03d}/{video_key}/episode_{episode_index:06d}.mp4"


@dataclass
class Legacy:
    """What `upgrade` needs of a v2.x dataset: its parsed meta files and every episode's files."""

    root: Path
    version: str
    info: dict[str, Any]
    episodes: list[dict[str, Any]]  # episodes.jsonl in episode_index order (its indices may have gaps)
    tasks: list[dict[str, Any]]  # tasks.jsonl, by task_index
    stats: dict[int, dict[str, Any]] | None  # episodes_stats.jsonl (v2.1), by position in `episodes`
    data: list[Path] = field(default_factory=list)  # per episode
    videos: dict[str, list[Path]] = field(default_factory=dict)  # per video key, per episode

    @property
    def numbers(self) -> list[int]:
        """Each episode's episode_index in OLD (0..n-1 unless episodes were deleted or a subset was kept)."""
        return [int(ep["episode_index"]) for ep in self.episodes]

    @property
    def features(self) -> dict[str, dict[str, Any]]:
        return self.info["features"]  # type: ignore[no-any-return]

    def keys_of(self, *dtypes: str) -> list[str]:
        return [k for k, ft in self.features.items() if ft.get("dtype") in dtypes]


def read_legacy(root: Path) -> Legacy:
    """`root` read as a v2.0/v2.1 dataset (see the module docstring); refused in one line otherwise."""
    for rel in (INFO, EPISODES, TASKS, EPISODES_STATS):  # a `meta/` symlink out of OLD, as every reader refuses
        contained(root, rel, str(root / rel))
    info = _info(root)
    episodes = _by_index(read_jsonl(root / EPISODES), "episode_index", root / EPISODES)
    tasks = _by_index(read_jsonl(root / TASKS), "task_index", root / TASKS)
    stats = None
    if (root / EPISODES_STATS).exists():
        rows = _by_index(read_jsonl(root / EPISODES_STATS), "episode_index", root / EPISODES_STATS)
        position = {int(ep["episode_index"]): e for e, ep in enumerate(episodes)}
        stats = {
            position[r["episode_index"]]: _stats_of(r, root / EPISODES_STATS)
            for r in rows
            if r["episode_index"] in position  # a line of an episode no longer listed is of no use
        }
    legacy = Legacy(root, str(info["codebase_version"]), info, episodes, tasks, stats)
    _find_files(legacy)
    return legacy


def _info(root: Path) -> dict[str, Any]:
    path = root / INFO
    try:
        info = read_json(path)
    except FileNotFoundError:
        raise DatasetError(f"{path}: missing; {root} is not a LeRobot dataset", code="dataset.invalid") from None
    if not isinstance(info, dict):
        raise DatasetError(f"{path}: not a JSON object", code="dataset.invalid")
    version = info.get("codebase_version")
    if isinstance(version, str) and version.startswith("v3"):
        raise DatasetError(
            f"{path}: codebase_version: already {version}; nothing to upgrade", code="dataset.unsupported"
        )
    if version not in VERSIONS:
        raise DatasetError(
            f"{path}: codebase_version: {version!r}; upgrade reads LeRobot v2.0 and v2.1", code="dataset.unsupported"
        )
    features = info.get("features")
    if not isinstance(features, dict) or not features:
        raise DatasetError(f"{path}: features: missing or not an object", code="dataset.invalid")
    for key, ft in features.items():
        if not isinstance(ft, dict) or not isinstance(ft.get("dtype"), str) or not isinstance(ft.get("shape"), list):
            raise DatasetError(f"{path}: features: {key}: needs a dtype and a shape", code="dataset.invalid")
    fps = info.get("fps")
    if isinstance(fps, bool) or not isinstance(fps, int | float) or not math.isfinite(fps) or fps <= 0:
        raise DatasetError(f"{path}: fps: {fps!r} is not a positive number", code="dataset.invalid")
    chunks = info.get("chunks_size", 1000)
    if isinstance(chunks, bool) or not isinstance(chunks, int) or chunks <= 0:
        raise DatasetError(f"{path}: chunks_size: {chunks!r} is not a positive integer", code="dataset.invalid")
    return info


def read_jsonl(path: Path) -> list[dict[str, Any]]:
    """Every line of a JSON-lines file, each a JSON object (`lerobot_v2.read_jsonl`, bounded); a missing file is
    one line too (OLD cannot be upgraded without it)."""
    try:
        return lerobot_v2.read_jsonl(path)
    except FileNotFoundError:
        raise DatasetError(f"{path}: missing", code="dataset.incomplete") from None


def _by_index(rows: list[dict[str, Any]], key: str, path: Path) -> list[dict[str, Any]]:
    """`rows` sorted by their integer `key`, each listed once (gaps are allowed: episodes are renumbered)."""
    for n, row in enumerate(rows, 1):
        value = row.get(key)
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise DatasetError(
                f"{path}: line {n}: {key}: {value!r} is not an index (an integer >= 0)", code="dataset.invalid"
            )
    rows = sorted(rows, key=lambda r: int(r[key]))
    for before, row in itertools.pairwise(rows):
        if before[key] == row[key]:
            raise DatasetError(f"{path}: {key}: {row[key]} is listed twice", code="dataset.invalid")
    return rows


def _stats_of(row: dict[str, Any], path: Path) -> dict[str, Any]:
    stats = row.get("stats")
    if not isinstance(stats, dict) or not all(isinstance(v, dict) for v in stats.values()):
        raise DatasetError(
            f"{path}: episode {row['episode_index']}: stats: not an object of per-feature objects",
            code="dataset.invalid",
        )
    return stats


def _find_files(legacy: Legacy) -> None:
    """Every listed episode's data file and (per video key) mp4, by info.json's templates; missing ones refused."""
    info, root = legacy.info, legacy.root
    if not legacy.episodes:
        raise DatasetError(f"{root / EPISODES}: lists no episode", code="dataset.invalid")
    if not legacy.tasks:
        raise DatasetError(f"{root / TASKS}: lists no task", code="dataset.invalid")
    for n, ep in enumerate(legacy.episodes, 1):
        length = ep.get("length")
        if isinstance(length, bool) or not isinstance(length, int) or length < 1:
            raise DatasetError(f"{root / EPISODES}: line {n}: length: {length!r}", code="dataset.invalid")
    chunks = int(info.get("chunks_size", 1000))
    video_keys = legacy.keys_of("video")
    for key in video_keys:
        safe_name(key, f"{root / INFO}: features")
    for e in legacy.numbers:
        # `chunk_index`: what some scripts of their own name the chunk in a v2.1 template (lerobot: episode_chunk)
        values = {"episode_chunk": e // chunks, "chunk_index": e // chunks, "episode_index": e}
        legacy.data.append(_file(root, info, "data_path", DATA_TEMPLATE, values))
        for key in video_keys:
            path = _file(root, info, "video_path", VIDEO_TEMPLATE, {**values, "video_key": key})
            legacy.videos.setdefault(key, []).append(path)


def _file(root: Path, info: dict[str, Any], name: str, default: str, values: dict[str, Any]) -> Path:
    path = from_template(root, info.get(name) or default, values, f"{root / INFO}: {name}")
    try:
        return regular_file(path)
    except FileNotFoundError:
        raise DatasetError(
            f"{path}: missing (episode {values['episode_index']}); upgrade needs every episode's files",
            code="dataset.incomplete",
        ) from None


def check_videos(legacy: Legacy, lengths: list[int]) -> None:
    """Every episode's mp4 holds at least its frames (packets counted, nothing decoded): lerobot's converter
    concatenates a shorter one as it is, and its loader then fails on the episode's last frames."""
    import av

    from openral_data.formats.lerobot_v3.video import probe_frames

    for videos in legacy.videos.values():
        for e, (path, n) in enumerate(zip(videos, lengths, strict=True)):
            try:
                frames = probe_frames(path)
            except (av.error.FFmpegError, IndexError) as exc:
                raise DatasetError(f"{path}: not a readable video: {exc}", code="dataset.invalid") from None
            if frames < n:
                raise DatasetError(
                    f"{path}: {frames} frames, but episode {legacy.numbers[e]} has {n}", code="dataset.invalid"
                )
