"""Findings: why an episode raised a flag, to the frame (docs/stats.md, "Quality", "Findings").

Every measure that can raise a flag says, for each thing it found, one `Finding`:

* `check`: the flag it raises (a name of `table.FLAGS`: `idle`, `frozen`, `jerky`, `clipped`, `camera_black`...)
  or, with `flag` False, an informational check that raises none (`INFO_CHECKS`: `constant`, `saturated`);
* `subject`: what it is about. A state/action dimension is `feature[name]` (`action[a1]`,
  `observation.state[shoulder_pan]`, the name from info.json's `names`, else `feature[i]` — `signals.Signal`
  names columns the same way); a camera is its feature key (`observation.images.top`); `timestamp` for the
  timing checks; `episode` for what is about all of it (idle time);
* `start_frame`, `end_frame`: the span that raised it, frame positions in the episode, both inclusive (None when
  the finding has no span);
* `value` against `threshold`: the measure and the threshold it crossed, in the check's own units (docs/stats.md
  lists them);
* `detail`: one short human line.

An episode's flag `X` is raised exactly when it has a finding of check `X` with `flag` True: the flags are
derived from the findings, never computed apart. The rows are cached beside the other quality tables
(`quality_findings.parquet`, `FINDING_SCHEMA` plus `episode_index`) and seen by DuckDB as the view
`quality_findings`; the `quality` table's `findings` column lists each episode's flagging findings as
`check:subject` strings, so `--where "list_contains(quality.findings, 'frozen:observation.state[j1]')"` names one
check on one dimension.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import asdict, dataclass

import numpy as np
import numpy.typing as npt
import pyarrow as pa

INFO_CHECKS = ("constant", "saturated")  # informational: listed, never flagged
MAX_SPANS = 5  # spans kept per (check, subject): the longest ones


@dataclass(frozen=True)
class Finding:
    check: str
    subject: str
    start_frame: int | None
    end_frame: int | None
    value: float | None
    threshold: float | None
    flag: bool = True
    detail: str = ""

    @property
    def label(self) -> str:
        """`check:subject`, as the `quality` table's `findings` column lists it."""
        return f"{self.check}:{self.subject}"


FINDING_SCHEMA = pa.schema(
    [
        ("episode_index", pa.int64()),
        ("check", pa.string()),
        ("subject", pa.string()),
        ("start_frame", pa.int64()),
        ("end_frame", pa.int64()),
        ("value", pa.float64()),
        ("threshold", pa.float64()),
        ("flag", pa.bool_()),
        ("detail", pa.string()),
    ]
)


def dim_subject(feature: str, name: str) -> str:
    """A dimension's subject: `feature[name]`."""
    return f"{feature}[{name}]"


def runs(mask: npt.NDArray[np.bool_], min_length: int = 1) -> list[tuple[int, int]]:
    """The runs of True in `mask` at least `min_length` long, as (first, last) frame positions (inclusive)."""
    edges = np.diff(np.concatenate([[0], np.asarray(mask, dtype=np.int8), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return [(int(a), int(b) - 1) for a, b in zip(starts, ends, strict=True) if b - a >= min_length]


def longest(spans: Iterable[tuple[int, int]], keep: int = MAX_SPANS) -> list[tuple[int, int]]:
    """The `keep` longest of `spans`, in frame order."""
    chosen = sorted(spans, key=lambda s: (s[0] - s[1], s[0]))[:keep]
    return sorted(chosen)


def span_findings(
    check: str,
    subject: str,
    spans: Iterable[tuple[int, int]],
    value: float | None,
    threshold: float | None,
    flag: bool = True,
    detail: str = "",
) -> list[Finding]:
    """One finding per span (the `MAX_SPANS` longest), all with the same measure."""
    return [Finding(check, subject, a, b, value, threshold, flag, detail) for a, b in longest(spans)]


def finding_rows(episode: int, findings: Iterable[Finding]) -> list[dict[str, object]]:
    return [{"episode_index": episode, **asdict(f)} for f in findings]


def flagged_checks(findings: Iterable[Finding]) -> set[str]:
    return {f.check for f in findings if f.flag}


def labels(findings: Iterable[Finding]) -> list[str]:
    """The distinct `check:subject` of the flagging findings, in order of first appearance."""
    return list(dict.fromkeys(f.label for f in findings if f.flag))
