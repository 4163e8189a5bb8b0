"""`doctor`'s checks, in the order a reader meets the files."""

from __future__ import annotations

from pathlib import Path

from openral_data.doctor import check_data, check_meta, check_paths, check_video
from openral_data.doctor.findings import Finding, warning
from openral_data.doctor.inspect import Dataset, load
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.lock import holder
from openral_data.formats.lerobot_v3.recovery import staged_files


def check(root: Path, *, lock_held_by_us: bool = False) -> list[Finding]:
    """Every finding for the dataset at `root` (ours or lerobot's); an empty list means healthy."""
    findings = leftovers(root, lock_held_by_us) + check_paths.check_controls(root)
    ds, fatal = load(root)
    if ds is None:
        return findings + fatal
    unsafe = check_paths.check_dataset_paths(ds)
    if any(f.code in check_paths.BLOCKING for f in unsafe):
        return findings + ds.problems + unsafe  # the other checks would build paths from those values
    return findings + unsafe + check_dataset(ds)


def check_dataset(ds: Dataset) -> list[Finding]:
    out = list(ds.problems)
    out += check_meta.check_info(ds)
    out += check_meta.check_tasks(ds)
    out += check_meta.check_episodes(ds)
    out += check_data.check_columns(ds)
    out += check_data.check_rows(ds)
    out += check_meta.check_totals(ds)
    out += check_data.check_episode_rows(ds)
    if not any(f.code == "episodes.order" for f in out):
        out += check_video.check_videos(ds)
        out += check_video.check_orphans(ds)
    out += check_meta.check_stats(ds)
    return out


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
