"""`doctor`'s checks, in the order a reader meets the files."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from openral_data.doctor import check_data, check_meta, check_missing, check_paths, check_video
from openral_data.doctor.check_deep import check_deep
from openral_data.doctor.check_digests import check_digests
from openral_data.doctor.check_scan import check_scan
from openral_data.doctor.check_v2 import check_v2, legacy_version
from openral_data.doctor.findings import Finding, error, warning
from openral_data.doctor.inspect import DAMAGE, Dataset, load
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.lock import holder
from openral_data.formats.lerobot_v3.recovery import staged_files

Check = Callable[[Dataset], list[Finding]]


def check(root: Path, *, lock_held_by_us: bool = False, deep: bool = False) -> list[Finding]:
    """Every finding for the dataset at `root` (ours or lerobot's); an empty list means healthy.

    Never raises on a damaged dataset: a file that cannot be read, or a check that fails on what it read,
    becomes an error finding. `deep` also decodes every video frame (`check_deep`)."""
    findings = leftovers(root, lock_held_by_us) + check_paths.check_controls(root)
    links = check_paths.check_links(root)
    if links:
        return findings + links  # every other check would read the files they lead to
    if legacy_version(root):
        return findings + check_v2(root, deep=deep)  # LeRobot v2.x: its own layout's checks
    ds, fatal = load(root)
    if ds is None:
        return findings + fatal
    unsafe = _run(check_paths.check_dataset_paths, ds)
    if any(f.code in check_paths.BLOCKING for f in unsafe):
        return findings + ds.problems + unsafe  # the other checks would build paths from those values
    return findings + unsafe + check_dataset(ds, deep=deep)


def _run(step: Check, ds: Dataset) -> list[Finding]:
    try:
        return step(ds)
    except DAMAGE as exc:
        name = step.__name__.removeprefix("check_")
        return [error("check.failed", "dataset", f"the {name} check cannot read the dataset: {exc!r}")]


def check_dataset(ds: Dataset, *, deep: bool = False) -> list[Finding]:
    out = list(ds.problems)
    for step in (
        check_missing.check_missing,
        check_meta.check_info,
        check_meta.check_provenance,
        check_meta.check_tasks,
        check_meta.check_episodes,
        check_data.check_columns,
        check_data.check_rows,
        check_meta.check_totals,
        check_data.check_episode_rows,
    ):
        out += _run(step, ds)
    if not any(f.code == "episodes.order" for f in out):
        out += _run(check_video.check_videos, ds)
        out += _run(check_video.check_orphans, ds)
        if deep:
            out += _run(check_deep, ds)
    out += _run(check_meta.check_stats, ds)
    out += _run(check_digests, ds)
    out += _run(check_signals, ds)
    return out


def check_signals(ds: Dataset) -> list[Finding]:
    """What the frames mean (`check_scan`), once the layout checks found the data files readable."""
    return check_scan(ds.root, ds.info, ds.data_files)


def leftovers(root: Path, lock_held_by_us: bool = False) -> list[Finding]:
    """Traces of a writer: a live one (everything may still change), or a killed one (temp files; the journal
    is `check_paths.check_controls`'s, which checks it is safe to replay)."""
    out: list[Finding] = []
    who = None if lock_held_by_us else holder(root)
    if who is not None:
        out.append(warning("writer.active", layout.LOCK_PATH, f"a writer is working on this dataset now ({who})"))
    staged = list(staged_files(root)) if who is None else []
    if staged:
        names = ", ".join(str(p.relative_to(root)) for p in staged[:3])
        message = f"{len(staged)} temporary file(s) of an unfinished write: {names}"
        out.append(warning("writer.staged", "dataset", message, repairable=True))
    return out
