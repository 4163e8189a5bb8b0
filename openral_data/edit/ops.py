"""Episode editing: delete, split and merge LeRobot v3 datasets (ours or lerobot's, see `edit.source`).

Every operation writes a new dataset (episodes re-indexed 0..n-1 in the order chosen, data `index`, episodes
metadata offsets, tasks, stats, video files and timestamps, info totals, `meta/openral.json` with an `edit`
block naming the sources) into a hidden sibling folder, fsyncs it and renames it to the output: the output
appears complete or not at all, and an existing output is refused before any work. Inputs are only read,
unless `delete --in-place` asks for the input to be replaced (the old folder is kept until the swap is done).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from openral_data.edit.assemble import EpisodeAssembler
from openral_data.edit.source import EpisodeData, SourceDataset
from openral_data.episodes import parse_episodes
from openral_data.errors import DatasetError, EpisodeSelectionError, UsageError
from openral_data.formats import progress
from openral_data.formats.lerobot_v3.config import WriterConfig
from openral_data.formats.lerobot_v3.lock import DatasetLock
from openral_data.formats.lerobot_v3.provenance import EditRecord, EditSource, Origin
from openral_data.formats.lerobot_v3.stats import ImageStatsAccumulator
from openral_data.formats.lerobot_v3.variants import comparable
from openral_data.formats.staging import Staging, check_new_output
from openral_data.formats.write_errors import disk_errors
from openral_data.types import DatasetSchema

_DATASET_ENTRIES = {"meta", "data", "videos", ".openral"}
_LEROBOT_IMAGES = "images"  # lerobot's staging folder for `dtype: image` PNGs, left empty once they are embedded
Selection = list[tuple[SourceDataset, int]]  # (source, episode index in it), in output order
Transform = Callable[[EpisodeData], EpisodeData]  # an episode as read -> as written


@dataclass(frozen=True)
class EditResult:
    out: Path
    episodes: int
    frames: int


@dataclass(frozen=True)
class Rewrite:
    """How an edit changes what it copies, beyond choosing episodes (`tasks`, `features remove`, `stats
    recompute`, `videos`): `transform` rewrites each episode read from a source before it is written; `schema`,
    `features` and `config` (writer settings) replace the first source's (a feature removed: schema and features
    name the same columns and cameras); `image_hist` are exact dataset-level camera histograms of the episodes
    written and `column_hist` the same for carried `dtype: image` features (both may be filled by `transform` as
    it goes: they are read at the end); `details`, what the change was, join the `edit` block of
    `meta/openral.json`; `aligned`: the caller checked that the sources share one episode table once
    `transform` ran (`align`: a merge re-encoding what differs), so their features are not compared as stored.
    """

    transform: Transform | None = None
    schema: DatasetSchema | None = None
    features: dict[str, dict[str, Any]] | None = None
    config: WriterConfig | None = None
    image_hist: dict[str, ImageStatsAccumulator] | None = None
    column_hist: dict[str, ImageStatsAccumulator] | None = None
    details: dict[str, Any] = field(default_factory=dict)
    aligned: bool = False


def check_compatible(first: SourceDataset, other: SourceDataset) -> None:
    """Refuse datasets that cannot share one episode table, naming the first field that differs."""
    where = f"{other.root}/meta/info.json"
    if other.fps != first.fps:
        raise DatasetError(
            f"{where}: fps: {other.fps} differs from {first.root}'s {first.fps}", code="dataset.mismatch"
        )
    if other.info.get("robot_type") != first.info.get("robot_type"):
        raise DatasetError(
            f"{where}: robot_type: {other.info.get('robot_type')!r} differs from "
            f"{first.root}'s {first.info.get('robot_type')!r}",
            code="dataset.mismatch",
        )
    field = first_difference(comparable(first.features), comparable(other.features), "features")
    if field is not None:
        raise DatasetError(f"{where}: {field}: differs from {first.root}", code="dataset.mismatch")


def first_difference(a: Any, b: Any, path: str) -> str | None:
    """The path of the first key or value where `a` and `b` differ, with both values (None when equal)."""
    if isinstance(a, dict) and isinstance(b, dict):
        for key in list(a) + [k for k in b if k not in a]:
            if key not in a or key not in b:
                return f"{path}.{key} (present in only one dataset)"
            found = first_difference(a[key], b[key], f"{path}.{key}")
            if found is not None:
                return found
        return None
    if a != b:
        return f"{path} ({b!r} vs {a!r})"
    return None


def write_selection(
    selection: Selection,
    out: Path,
    op: str,
    on_episode: Callable[[int], None] | None = None,
    before_publish: Callable[[Path], None] | None = None,
    image_hist: dict[str, ImageStatsAccumulator] | None = None,
    before_rename: Callable[[], None] | None = None,
    out_checked: bool = False,
    rewrite: Rewrite | None = None,
) -> EditResult:
    """Write the selected episodes, in order, as a new dataset at `out` (atomically, through `staging.Staging`).

    `before_publish(staging)` may add files beside the dataset (e.g. `mcap/`) before the whole folder appears;
    `before_rename()` runs right before the rename (`record --workers` lets go of its lock on `out` there);
    `out_checked`: the caller checked `out` itself and holds it (its lock file is in it until `before_rename`).
    `rewrite`: what the edit changes in the episodes besides their selection (its `image_hist` replaces the
    argument's).
    """
    change = rewrite or Rewrite()
    first = _check_selection(selection, out, out_checked, not change.aligned)
    cameras = list((change.schema or first.schema).cameras)  # the video cameras written (a dropped one is not read)
    _check_present(selection, cameras, op)
    provenance = _provenance(selection, op, change)
    staged = Staging(out, f"openral-data {op}")
    with disk_errors(out, f"writing the {op} output"), staged as staging:
        writer = EpisodeAssembler(
            staging,
            change.schema or first.schema,
            change.config or first.writer_config(),
            provenance,
            change.image_hist if rewrite is not None else image_hist,
            features=change.features or first.features,
            column_hist=change.column_hist,
        )
        _copy(selection, writer, change.transform, on_episode, cameras)
        frames = writer.total_frames
        if before_publish is not None:
            before_publish(staging)
        staged.publish(before_rename=before_rename)
    return EditResult(out, len(selection), frames)


def _check_selection(selection: Selection, out: Path, out_checked: bool, compare: bool = True) -> SourceDataset:
    """The first source of a non-empty selection whose sources all share its episode table (unless not
    `compare`); `out` new or empty (unless `out_checked`)."""
    if not selection:
        raise EpisodeSelectionError(f"{out}: no episodes selected; a dataset needs at least one", code="episodes.empty")
    first = selection[0][0]
    for src, _ in selection:
        if compare and src is not first:
            check_compatible(first, src)
    if not out_checked:
        check_new_output(out)
    return first


def _check_present(selection: Selection, cameras: list[str], op: str) -> None:
    """Refuse, before any work, a selection whose data or `cameras`' videos a partial download left out (only
    the files copied are needed: `features remove` of an absent camera works)."""
    episodes: dict[SourceDataset, list[int]] = {}
    for src, e in selection:
        episodes.setdefault(src, []).append(e)
    for src, eps in episodes.items():
        src.need(eps, cameras, _command(op))


def _command(op: str) -> str:
    """The command an edit's `op` is (`delete` is `episodes delete`; `tasks rename`, `stats recompute`, …)."""
    return f"episodes {op}" if op in ("delete", "filter", "split", "merge", "trim", "resample") else op


def _provenance(selection: Selection, op: str, change: Rewrite) -> EditRecord:
    """The `edit` block of `meta/openral.json`: the operation, each source with its episodes, what changed."""
    sources: dict[Path, list[int]] = {}
    for src, e in selection:
        sources.setdefault(src.root, []).append(e)
    return EditRecord(
        op,
        [EditSource(str(root.resolve()), list(eps), _meta_of(selection, root)) for root, eps in sources.items()],
        dict(change.details),
    )


def _copy(
    selection: Selection,
    writer: EpisodeAssembler,
    transform: Transform | None,
    on_episode: Callable[[int], None] | None,
    cameras: list[str],
) -> None:
    """Every selected episode, read (with the videos of `cameras`), rewritten by `transform` and added in order;
    the writer closed, or aborted by whatever stopped the copy."""
    try:
        for k, (src, e) in enumerate(selection):
            episode = src.episode(e, cameras)
            writer.add(episode if transform is None else transform(episode))
            if on_episode is not None:
                on_episode(k)
            progress.tick(k + 1, len(selection))  # the CLI's progress bar, when it set one
    except BaseException:
        writer.abort()  # the staging folder is discarded: the error that stopped the copy is the one to report
        raise
    writer.close()


def _meta_of(selection: Selection, root: Path) -> Origin:
    src = next(s for s, _ in selection if s.root == root)
    return src.origin


# -- the operations by index ------------------------------------------------------------------------------------
def delete(dataset: Path, episodes: str, out: Path | None, in_place: bool = False) -> EditResult:
    src = SourceDataset(dataset)
    drop = set(parse_episodes(episodes, src.total))
    keep = [(src, e) for e in range(src.total) if e not in drop]
    if not keep:
        raise EpisodeSelectionError(
            f"--episodes: {episodes} would delete every episode of {dataset}", code="episodes.empty"
        )
    return write_edit(keep, dataset, out, in_place, "delete")


def check_edit_output(out: Path | None, in_place: bool) -> None:
    """Refuse an edit's output before any work: exactly one of `--out DIR` (new or empty) and `--in-place`."""
    if in_place == (out is not None):
        raise UsageError("--out: give either --out DIR or --in-place")
    if out is not None:
        check_new_output(out)


def write_edit(
    keep: Selection, dataset: Path, out: Path | None, in_place: bool, op: str, rewrite: Rewrite | None = None
) -> EditResult:
    """Write `keep` (episodes of `dataset`) to `out`, or (`in_place`) as `dataset` itself, swapped in once complete."""
    check_edit_output(out, in_place)
    if out is not None:
        return write_selection(keep, out, op, rewrite=rewrite)
    given, dataset = dataset, dataset.resolve()  # a DATASET given as a symlink: the real folder is edited in place
    # lerobot leaves empty `images/<key>/` folders behind: nothing is lost without them
    foreign = sorted(
        p.name
        for p in dataset.iterdir()
        if p.name not in _DATASET_ENTRIES and not (p.name == _LEROBOT_IMAGES and _empty_folder(p))
    )
    if foreign:
        raise UsageError(
            f"{dataset}: --in-place: {', '.join(foreign)} would not be carried over (editing writes meta/, data/ "
            "and videos/ only); use --out"
        )
    old = dataset.parent / f".{dataset.name}.replaced-{os.getpid()}"
    command = _command(op)
    staged = Staging(dataset, f"openral-data {command} --in-place")
    lock = DatasetLock(dataset, f"{command} --in-place")
    with lock, disk_errors(dataset, f"replacing it by its {op} edit"), staged as new:  # no recording meanwhile
        result = write_selection(keep, new, op, rewrite=rewrite)
        staged.replace_existing(old)  # the input stays whole (under `old`) until the new dataset took its name
    return EditResult(given, result.episodes, result.frames)


def _empty_folder(path: Path) -> bool:
    """A real folder holding nothing but (real) empty folders."""
    if path.is_symlink() or not path.is_dir():
        return False
    return all(_empty_folder(p) for p in path.iterdir())


def split(dataset: Path, episodes: str, out: Path, rest: Path | None = None) -> list[EditResult]:
    """`out` gets the listed episodes (in the order listed); `rest`, if given, gets the others in order."""
    src = SourceDataset(dataset)
    chosen = parse_episodes(episodes, src.total)
    others = [e for e in range(src.total) if e not in set(chosen)]
    check_new_output(out)
    if rest is not None:
        check_new_output(rest)
        if not others:
            raise EpisodeSelectionError(
                f"--rest: {episodes} selects every episode; nothing is left for {rest}", code="episodes.empty"
            )
    results = [write_selection([(src, e) for e in chosen], out, "split")]
    if rest is not None:
        results.append(write_selection([(src, e) for e in others], rest, "split"))
    return results


def merge(datasets: Sequence[Path], out: Path, order: str = "input") -> EditResult:
    """Concatenate datasets (same features); `order="seed"` sorts all episodes by their recording seed."""
    if not datasets:
        raise UsageError("merge: give at least one dataset")
    sources = [SourceDataset(p) for p in datasets]
    for other in sources[1:]:
        check_compatible(sources[0], other)
    selection: Selection = [(s, e) for s in sources for e in range(s.total)]
    if order == "seed":
        selection.sort(key=lambda se: se[0].seed(se[1]))  # stable: equal seeds keep input order
    elif order != "input":
        raise UsageError(f"--order: {order!r} is not one of input, seed")
    return write_selection(selection, out, "merge", image_hist=summed_histograms(sources))


def summed_histograms(sources: Sequence[SourceDataset]) -> dict[str, ImageStatsAccumulator] | None:
    """Camera histograms of whole datasets, summed (exact stats for their concatenation); None if one lacks them."""
    total: dict[str, ImageStatsAccumulator] | None = None
    for src in sources:
        hist = src.image_hist()
        if hist is None or hist.keys() != set(src.camera_names()):
            return None
        if src.total != src.episodes.num_rows:  # the histograms may include rows beyond info's total
            return None
        if total is None:
            total = {name: ImageStatsAccumulator() for name in hist}
        for name, acc in hist.items():
            total[name].merge(acc)
    return total
