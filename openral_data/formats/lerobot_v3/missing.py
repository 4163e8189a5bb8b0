"""Which files of a LeRobot v3 dataset are absent (a partial download), and which of them a command needs.

`hf download REPO --include 'meta/*' 'data/*'` leaves ``videos/`` out; an interrupted download leaves some files
out. Such a dataset is not damaged: every command that does not need a file must work without it, and one that
does names it. This module is the one place that knows which files the committed episodes name (their data
parquet and, per video camera, their mp4: the `layout` paths of their episodes rows) and which are absent
(nothing at the path: a file that is there but not a regular file is another problem, refused by the readers).

`missing_files` finds them; `MissingFiles.line`/`to_json`/`kinds` is what `info`, `stats` and `doctor` show;
`MissingFiles.need` is the one-line refusal of a command that needs some of them (``dataset.incomplete``), with
the ``hf download`` command that fetches the rest.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pyarrow as pa

from openral_data.errors import DatasetError
from openral_data.formats.lerobot_v3 import layout

SHOWN = 2  # file names a summary shows per kind


@dataclass(frozen=True)
class Absent:
    """The absent files of one kind (`kind`: ``data`` or ``videos/<camera>``): each with its episodes, how many
    files of that kind the episodes name, and the ``--include`` pattern that fetches them."""

    kind: str
    files: dict[str, list[int]]
    named: int
    pattern: str

    def episodes(self) -> list[int]:
        return sorted({e for eps in self.files.values() for e in eps})

    def summary(self) -> str:
        """``2 of 3 files (file-000.mp4, file-001.mp4 …)``."""
        return f"{len(self.files)} of {self.named} files ({_names(sorted(self.files))})"


@dataclass(frozen=True)
class MissingFiles:
    """The absent files of a dataset, each with the episodes it holds.

    `data`: relative data parquet path -> episode indices; `videos`: camera key -> relative mp4 path -> episode
    indices; `named_data` / `named_videos`: how many files the episodes name in all (the "of N"); `stats`:
    ``meta/stats.json`` is absent."""

    root: Path
    data: dict[str, list[int]] = field(default_factory=dict)
    videos: dict[str, dict[str, list[int]]] = field(default_factory=dict)
    named_data: int = 0
    named_videos: dict[str, int] = field(default_factory=dict)
    stats: bool = False

    def __bool__(self) -> bool:
        return bool(self.data or any(self.videos.values()) or self.stats)

    def files(self) -> list[str]:
        """Every absent file, relative to the root: data, videos, then meta/stats.json."""
        out = list(self.data) + [p for files in self.videos.values() for p in files]
        return out + ([layout.STATS_PATH] if self.stats else [])

    def kinds(self) -> list[Absent]:
        """The absent files by kind: data, then each camera's videos (only kinds with absent files)."""
        out = [Absent("data", self.data, self.named_data, "data/*")] if self.data else []
        for key, files in self.videos.items():
            if files:
                out.append(Absent(f"videos/{key}", files, self.named_videos.get(key, 0), f"videos/{key}/*"))
        return out

    def line(self) -> str | None:
        """One compact line for `info`, None when nothing is missing, e.g. ``missing: videos/observation.images.cam
        2 of 3 files (file-000.mp4, file-001.mp4 …); fetch them: hf download …``."""
        if not self:
            return None
        parts = [f"{a.kind} {a.summary()}" for a in self.kinds()] + ([layout.STATS_PATH] if self.stats else [])
        return f"missing: {'; '.join(parts)}; fetch them: {self.fetch_hint()}"

    def to_json(self) -> dict[str, object]:
        """`info --json`'s `missing` field: the absent files by kind (paths relative to the root)."""
        return {
            "data": list(self.data),
            "videos": {k: list(v) for k, v in self.videos.items() if v},
            "stats": self.stats,
        }

    def fetch_hint(self) -> str:
        """The `hf download` command that fetches the absent files into this folder (the repo id is the user's)."""
        return fetch_hint(self.root, [a.pattern for a in self.kinds()] + ([layout.STATS_PATH] if self.stats else []))

    def need(self, episodes: Iterable[int] | None, cameras: Iterable[str], what: str, drop: bool = False) -> None:
        """Refuse in one line (``dataset.incomplete``) when the data of `episodes` (None: all) or the videos of
        `cameras` (keys) for them are absent: `what` is what needs them (e.g. ``episodes delete``); `drop`: an edit,
        which can drop a camera instead (`features remove`), says so when the file is a camera's."""
        wanted = None if episodes is None else set(episodes)
        absent: list[tuple[str, str]] = []
        for kind, files in [("data", self.data)] + [(k, self.videos.get(k, {})) for k in cameras]:
            absent += [(p, kind) for p, eps in files.items() if wanted is None or any(e in wanted for e in eps)]
        if not absent:
            return
        more = f" (and {len(absent) - 1} more file(s))" if len(absent) > 1 else ""
        path, kind = absent[0]
        camera = drop and kind != "data"
        instead = f"; or drop that camera first: features remove {self.root} --feature {kind}" if camera else ""
        raise DatasetError(
            f"{self.root / path}: {kind}: missing, not downloaded{more}, and {what} needs it; fetch the rest: "
            f"{self.fetch_hint()}{instead}",
            code="dataset.incomplete",
        )


def fetch_hint(root: Path, patterns: Sequence[str]) -> str:
    """The `hf download` command that fetches the files `patterns` match into the dataset folder `root` (the
    Hub's repo id is the user's to fill in)."""
    include = " ".join(f"'{p}'" for p in patterns)
    return f"hf download REPO_ID --repo-type dataset --include {include} --local-dir {root}"


def _names(paths: Sequence[str]) -> str:
    shown = ", ".join(Path(p).name for p in paths[:SHOWN])
    return shown + (" …" if len(paths) > SHOWN else "")


def missing_files(
    root: Path, info: dict[str, Any], episodes: pa.Table | list[dict[str, Any]], keys: Iterable[str] | None = None
) -> MissingFiles:
    """The absent files the committed `episodes` rows (meta/episodes) name: their data parquet, the mp4 of each
    video camera in `keys` (default: every `dtype: video` feature of `info`), and ``meta/stats.json``. Rows
    without a file's columns name no file (a malformed table is the readers' and doctor's to report); a path
    a symlink leads outside `root` is refused in one line (`layout.inside`)."""
    if keys is None:
        keys = [k for k, f in info.get("features", {}).items() if isinstance(f, dict) and f.get("dtype") == "video"]
    keys = list(keys)
    if isinstance(episodes, pa.Table):  # only the columns that name files (not the many stats/* columns)
        wanted = {"episode_index"} | {
            f"{p}/{i}_index" for p in ["data", *(f"videos/{k}" for k in keys)] for i in ("chunk", "file")
        }
        episodes = episodes.select([c for c in episodes.column_names if c in wanted])
    rows: list[dict[str, Any]] = episodes.to_pylist() if isinstance(episodes, pa.Table) else episodes
    data, named_data = _absent(rows, "data", lambda pos: layout.template_path(root, info, "data_path", pos), root)
    videos: dict[str, dict[str, list[int]]] = {}
    named_videos: dict[str, int] = {}
    for key in keys:
        videos[key], named_videos[key] = _absent(rows, f"videos/{key}", _video_of(root, info, key), root)
    # a v2.1 dataset keeps its stats per episode (meta/episodes_stats.jsonl): no meta/stats.json is due
    stats = info.get("codebase_version") != "v2.1" and not os.path.lexists(root / layout.STATS_PATH)
    return MissingFiles(root, data, videos, named_data, named_videos, stats)


def _video_of(root: Path, info: dict[str, Any], key: str) -> Callable[[layout.FilePos], Path]:
    return lambda pos: layout.template_path(root, info, "video_path", pos, video_key=key)


def _absent(
    rows: list[dict[str, Any]], prefix: str, path_of: Callable[[layout.FilePos], Path], root: Path
) -> tuple[dict[str, list[int]], int]:
    """(absent file -> its episodes, how many files the rows name) for the files `prefix`'s columns name."""
    named: dict[layout.FilePos, list[int]] = {}
    for row in rows:
        chunk, file = row.get(f"{prefix}/chunk_index"), row.get(f"{prefix}/file_index")
        episode = row.get("episode_index")
        if chunk is None or file is None or not isinstance(episode, int):
            continue  # names no file we could look for: the readers and doctor report such a row
        try:
            pos = layout.FilePos(chunk, file)
        except DatasetError as exc:
            raise DatasetError(
                f"{root / 'meta/episodes'}: {prefix}/chunk_index: episode {episode}: {exc}", code="dataset.invalid"
            ) from None
        named.setdefault(pos, []).append(episode)
    paths = {pos: path_of(pos) for pos in sorted(named)}  # each file's path checked once, not once per episode
    absent = {str(p.relative_to(root)): named[pos] for pos, p in paths.items() if not os.path.lexists(p)}
    return absent, len(named)
