"""The checks beyond motion and cameras, each a list of `Finding`s with frames: non-finite values, quaternion
sign flips and norms, angle wraps (`metrics.signals`, doctor's functions), duplicated dimensions, the task
text, duplicate episodes and episode-length outliers (docs/stats.md, "Quality")."""

from __future__ import annotations

import hashlib
import re
import unicodedata

import numpy as np
import numpy.typing as npt

from openral_data.metrics import signals
from openral_data.metrics.quality.findings import Finding, dim_subject, runs, span_findings
from openral_data.metrics.quality.thresholds import Thresholds

Array = npt.NDArray[np.float64]
PLACEHOLDER = re.compile(
    r"^\s*(todo|tbd|none|null|nan|n/?a|placeholder|xxx+|\.\.\.|-+|default( task)?|<[^>]*>|\{[^}]*\}|"
    r"lorem ipsum.*|insert task.*)\s*$",
    re.IGNORECASE,
)
MAX_PAIRS = 64  # dimensions compared pairwise for duplicates (a wider vector: its first 64)


def non_finite(x: Array, names: list[str], feature: str) -> list[Finding]:
    """`non_finite`: each run of NaN/Inf in each dimension; value: how many such frames in the dimension."""
    bad = ~np.isfinite(x)
    out: list[Finding] = []
    for d in np.flatnonzero(bad.any(axis=0)):
        spans = runs(bad[:, d])
        out += span_findings("non_finite", dim_subject(feature, names[d]), spans, float(bad[:, d].sum()), 0.0)
    return out


def quaternions(x: Array, names: list[str], feature: str, th: Thresholds) -> list[Finding]:
    """`quat_flip` at each frame where a quaternion turns to its negative (`signals.quaternion_flips`) and
    `quat_norm` over each run of frames whose quaternion's norm is off 1 by more than `quat_norm`."""
    out = [
        Finding("quat_flip", s.columns[0], f, f, float(s.count), 0.0, detail=s.detail)
        for s in signals.quaternion_flips(x, feature, names)
        for f in s.frames
    ]
    for label, dims in signals.quaternion_groups(feature, names):
        with np.errstate(invalid="ignore"):
            off = np.abs(np.linalg.norm(x[:, dims], axis=1) - 1.0)
        bad = off > th.quat_norm
        if bad.any():
            out += span_findings("quat_norm", label, runs(bad), float(np.nanmax(off)), th.quat_norm)
    return out


def angle_wraps(x: Array, names: list[str], feature: str, also: frozenset[int] = frozenset()) -> list[Finding]:
    """`angle_wrap` at each frame where an angle-like dimension (or one of `also`: the robot manifest's revolute
    joints) jumps by about 2π, or 360 in degrees (`signals.angle_wraps`)."""
    return [
        Finding("angle_wrap", s.columns[0], f, f, float(s.count), 0.0, detail=s.detail)
        for s in signals.angle_wraps(x, feature, names, also)
        for f in s.frames
    ]


def duplicated(x: Array, names: list[str], feature: str) -> list[Finding]:
    """`duplicated`: a dimension equal, frame for frame, to an earlier one of the same feature over the whole
    episode while it moves (a column written twice, or in place of another)."""
    n, d = x.shape
    if n < 2:
        return []
    moving = [i for i in range(min(d, MAX_PAIRS)) if np.nanmax(x[:, i]) > np.nanmin(x[:, i])]
    out = []
    for k, j in enumerate(moving):
        same = next((i for i in moving[:k] if np.array_equal(x[:, i], x[:, j])), None)
        if same is not None:
            detail = f"= {dim_subject(feature, names[same])}"
            out.append(Finding("duplicated", dim_subject(feature, names[j]), 0, n - 1, None, None, detail=detail))
    return out


def task_text(tasks: list[str]) -> list[Finding]:
    """`task_text`: an episode's task empty, a placeholder (`TODO`, `<task>`, `n/a`...), or holding control
    characters (a newline or a NUL pasted in)."""
    out = []
    for task in tasks or [""]:
        if not task.strip():
            what = "empty"
        elif PLACEHOLDER.match(task):
            what = "placeholder"
        elif any(unicodedata.category(c) == "Cc" for c in task):
            what = "control characters"
        else:
            continue
        out.append(Finding("task_text", "task", None, None, None, None, detail=f"{what}: {task[:40]!r}"))
    return out


def digest(arrays: dict[str, Array]) -> str:
    """A digest of an episode's state and action values (equal digests: the same frames)."""
    h = hashlib.sha256()
    for key in sorted(arrays):
        h.update(key.encode())
        h.update(np.ascontiguousarray(arrays[key]).tobytes())
    return h.hexdigest()


def duplicates(digests: dict[int, str]) -> dict[int, list[Finding]]:
    """`duplicate_episode`: an episode whose state and action are those of an earlier one, frame for frame."""
    first: dict[str, int] = {}
    out: dict[int, list[Finding]] = {}
    for e in sorted(digests):
        seen = first.setdefault(digests[e], e)
        if seen != e:
            out[e] = [
                Finding("duplicate_episode", "episode", None, None, float(seen), None, detail=f"= episode {seen}")
            ]
    return out


def length_outliers(lengths: dict[int, int], th: Thresholds) -> dict[int, list[Finding]]:
    """`length_outlier`: with at least 5 episodes, one more than `length_ratio` times shorter or longer than the
    median episode; value: its length over the median."""
    if len(lengths) < 5:
        return {}
    median = float(np.median(list(lengths.values())))
    out: dict[int, list[Finding]] = {}
    for e, n in lengths.items():
        ratio = n / median if median else 0.0
        if median and (ratio > th.length_ratio or ratio < 1 / th.length_ratio):
            out[e] = [
                Finding("length_outlier", "episode", 0, n - 1, ratio, th.length_ratio, detail=f"median {median:g}")
            ]
    return out
