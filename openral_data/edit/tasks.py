"""The tasks of a LeRobot v3 dataset: list them, rename one, set the task of chosen episodes.

`rename` and `set` rewrite the dataset through `ops.write_edit` (atomic, lock-aware, `--out` or `--in-place`):
every frame's `task_index`, `meta/tasks.parquet` and the episodes' `tasks` column follow the new texts. Task
indices are dense, numbered in order of first use; a task no frame uses any more disappears, and renaming a
task to the text of another one merges the two. Video packets and image cells are copied, never re-encoded.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

from openral_data.edit.ops import EditResult, Rewrite, Transform, summed_histograms, write_edit
from openral_data.edit.source import EpisodeData, SourceDataset
from openral_data.episodes import parse_episodes
from openral_data.errors import UsageError
from openral_data.formats.dataset import open_lerobot


@dataclass(frozen=True)
class TaskUse:
    index: int
    task: str
    episodes: list[int]  # the episodes whose meta/episodes `tasks` list names it, ascending


def list_tasks(dataset: Path) -> list[TaskUse]:
    """Every task of `dataset` in task_index order, with the episodes that use it (read only)."""
    ds = open_lerobot(dataset)  # any version: listing is read-only
    names = ds.tasks()
    episodes = ds.committed_episodes()
    using: dict[str, list[int]] = {t: [] for t in names}
    for row in episodes.to_pylist():
        for task in row.get("tasks") or []:
            if task in using:
                using[task].append(int(row["episode_index"]))
    return [TaskUse(i, t, sorted(using[t])) for i, t in enumerate(names)]


def rename(dataset: Path, old: str, new: str, out: Path | None, in_place: bool = False) -> EditResult:
    """Write `dataset` with task `old` called `new` (merged into `new` if that task exists)."""
    src = SourceDataset(dataset)
    text = _text(new, "--to")
    if old not in src.task_names:
        raise UsageError(f"--from: {dataset} has no task {old!r} (its tasks: {_names(src.task_names)})")

    def renamed(ep: EpisodeData) -> EpisodeData:
        return dataclasses.replace(ep, tasks=[text if t == old else t for t in ep.tasks])

    return _write(src, out, in_place, "tasks rename", renamed)


def set_task(dataset: Path, episodes: str, task: str, out: Path | None, in_place: bool = False) -> EditResult:
    """Write `dataset` with every frame of the listed episodes doing `task`."""
    src = SourceDataset(dataset)
    text = _text(task, "--task")
    chosen = set(parse_episodes(episodes, src.total))

    def assigned(ep: EpisodeData) -> EpisodeData:
        return dataclasses.replace(ep, tasks=[text] * ep.length) if ep.index in chosen else ep

    return _write(src, out, in_place, "tasks set", assigned)


def _write(src: SourceDataset, out: Path | None, in_place: bool, op: str, transform: Transform) -> EditResult:
    hist = summed_histograms([src])  # every episode is kept: the camera histograms stay exact
    rewrite = Rewrite(transform=transform, image_hist=hist)
    return write_edit([(src, e) for e in range(src.total)], src.root, out, in_place, op, rewrite)


def _text(task: str, flag: str) -> str:
    if not task.strip():
        raise UsageError(f"{flag}: empty task text")
    return task


def _names(names: list[str]) -> str:
    shown = ", ".join(repr(n) for n in names[:5])
    return shown + (f", … ({len(names)} in all)" if len(names) > 5 else "")
