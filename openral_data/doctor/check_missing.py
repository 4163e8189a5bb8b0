"""Files the episodes name that are not there: a partial download (`hf download --include 'meta/*' 'data/*'`, an
interrupted one), not damage. One warning per kind (``data.missing``; ``video.missing`` per camera) saying how
many of how many files, which episodes, and the ``hf download`` command that fetches them; lerobot's loader
itself downloads them from the Hub when it needs them. A path that is there but is not a regular file is
damage, reported by the check of that file. The other checks leave the absent files to this one (`absent`),
and `doctor --repair` rewrites nothing while data files are absent (`repair`): it would count what is there.
"""

from __future__ import annotations

from openral_data.doctor.findings import Finding, warning
from openral_data.doctor.inspect import DAMAGE, Dataset
from openral_data.formats.lerobot_v3.missing import MissingFiles, fetch_hint, missing_files

SHOWN = 5  # episodes a finding names
PARTIAL_DOWNLOAD = ("data.missing", "video.missing")  # the codes of files the episodes name that are absent


def absent(ds: Dataset) -> MissingFiles:
    """The absent files of `ds` (its committed episodes' data parquet and mp4), computed once."""
    if ds.missing is None:
        if ds.episodes is None or "episode_index" not in ds.episodes.column_names:
            ds.missing = MissingFiles(ds.root)
        else:
            rows = ds.episodes.slice(0, ds.total("total_episodes"))
            try:
                ds.missing = missing_files(ds.root, ds.info, rows, ds.video_keys)
            except DAMAGE:  # rows naming no usable file: the episodes and paths checks report them
                ds.missing = MissingFiles(ds.root)
    return ds.missing


def check_missing(ds: Dataset) -> list[Finding]:
    found = absent(ds)
    out: list[Finding] = []
    for kind in found.kinds():
        code = "data.missing" if kind.kind == "data" else "video.missing"  # PARTIAL_DOWNLOAD
        eps = kind.episodes()
        message = (
            f"{kind.summary()} not downloaded, episode(s) {eps[:SHOWN]}{' …' if len(eps) > SHOWN else ''}: a partial "
            f"download (commands that need them say so; lerobot fetches them from the Hub); fetch them: "
            f"{fetch_hint(ds.root, [kind.pattern])}"
        )
        out.append(warning(code, kind.kind, message))
    return out
