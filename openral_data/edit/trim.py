"""`episodes trim`: drop frames inside episodes, written as a new dataset (or in place) through the editing path
(`ops.write_edit`: atomic, lock-aware, episodes re-indexed, every later frame's `index` shifted).

- `--frames EP:START-END,...`: drop frames START..END of episode EP, both ends INCLUDED (as `--episodes 5-7`
  includes 7); `EP:F` drops one frame. Several spans of one episode may be given, not overlapping; an episode
  must keep at least one frame (`episodes delete` removes whole episodes).
- `--idle`: drop each episode's idle head and tail, the `idle_head`/`idle_tail` spans of `openral-data quality`
  (its cached table when current, else the same motion measures computed now, nothing cached), unless fewer
  than `--min-frames` frames (default `MIN_FRAMES`) would be left: such an episode is kept whole.

Frames are cut by `edit.subset` (packets copied when the kept runs fall on keyframes, else that episode's
camera re-encoded); episodes with nothing dropped are copied as they are.
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from openral_data.edit.ops import EditResult, Rewrite, check_edit_output, write_edit
from openral_data.edit.source import EpisodeData, SourceDataset
from openral_data.edit.subset import Counts, FrameSubset, Progress
from openral_data.episodes import position_of
from openral_data.errors import EpisodeSelectionError, UsageError
from openral_data.metrics.quality import DEFAULT, cached_quality
from openral_data.metrics.quality.compute import motion_pass
from openral_data.metrics.sources import open_dataset

MIN_FRAMES = 10
_SPAN = re.compile(r"([0-9]{1,18}):([0-9]{1,18})(?:-([0-9]{1,18}))?")
Drops = dict[int, list[tuple[int, int]]]  # episode -> dropped frames [start, end) in ascending order


def parse_frames(text: str, lengths: list[int]) -> Drops:
    """`--frames 0:0-4,2:10-12,2:20` -> {0: [(0, 5)], 2: [(10, 13), (20, 21)]}, checked against the episodes'
    `lengths`: each error one line naming the part."""
    drops: Drops = {}
    for part in (p.strip() for p in text.split(",")):
        m = _SPAN.fullmatch(part)
        if m is None:
            raise EpisodeSelectionError(
                f"--frames: {part!r} is not EPISODE:START-END or EPISODE:FRAME", code="episodes.syntax"
            )
        e, first = int(m[1]), int(m[2])
        last = int(m[3]) if m[3] is not None else first
        if e >= len(lengths):
            raise EpisodeSelectionError(
                f"--frames: {part!r}: episode {e} is outside the dataset's episodes 0..{len(lengths) - 1}",
                code="episodes.range",
            )
        if first > last or last >= lengths[e]:
            raise EpisodeSelectionError(
                f"--frames: {part!r}: frames {first}-{last} are outside episode {e}'s frames 0..{lengths[e] - 1}",
                code="episodes.range",
            )
        drops.setdefault(e, []).append((first, last + 1))
    for e, spans in drops.items():
        spans.sort()
        for (a, b), (c, d) in itertools.pairwise(spans):
            if c < b:
                raise EpisodeSelectionError(
                    f"--frames: episode {e}: frames {a}-{b - 1} and {c}-{d - 1} overlap", code="episodes.overlap"
                )
        if sum(b - a for a, b in spans) == lengths[e]:
            raise EpisodeSelectionError(
                f"--frames: every frame of episode {e} would be dropped; use episodes delete --episodes {e}",
                code="episodes.empty",
            )
    return drops


def idle_drops(dataset: Path, total: int, min_frames: int) -> Drops:
    """Each episode's idle head and tail (`quality`'s `idle_head`, `idle_tail`), where dropping them leaves at
    least `min_frames` frames."""
    ds = open_dataset(dataset)
    table = cached_quality(ds)
    if table is not None:
        rows = {
            int(r["episode_index"]): r for r in table.select(["episode_index", "idle_head", "idle_tail"]).to_pylist()
        }
    else:
        rows = motion_pass(ds, DEFAULT, lambda _: None)  # the per-frame rows are not needed
    lengths = {
        int(r["episode_index"]): int(r["length"]) for r in ds.read_episodes(["episode_index", "length"]).to_pylist()
    }
    drops: Drops = {}
    for e in range(total):
        row, n = rows.get(e), lengths.get(e, 0)
        if row is None:
            continue
        head, tail = int(row["idle_head"]), int(row["idle_tail"])
        if (head or tail) and n - head - tail >= min_frames:
            drops[e] = [span for span in ((0, head), (n - tail, n)) if span[1] > span[0]]
    return drops


def kept(drops: Drops) -> Callable[[EpisodeData], list[int] | None]:
    def picks(ep: EpisodeData) -> list[int] | None:
        spans = drops.get(ep.index)
        if not spans:
            return None
        gone = {k for a, b in spans for k in range(a, b)}
        return [k for k in range(ep.length) if k not in gone]

    return picks


def trim(
    dataset: Path,
    frames: str | None = None,
    idle: bool = False,
    min_frames: int = MIN_FRAMES,
    out: Path | None = None,
    in_place: bool = False,
    progress: Progress | None = None,
) -> tuple[EditResult, Counts]:
    """Write `dataset` without the frames `frames` names, or (`idle`) without its episodes' idle heads and tails;
    the result and what was done to its episodes' videos."""
    if (frames is None) == (not idle):
        raise UsageError("--frames: give either --frames EP:START-END,... or --idle")
    if min_frames < 1:
        raise UsageError(f"--min-frames: {min_frames} is not a positive number of frames")
    check_edit_output(out, in_place)  # before any reading
    src = SourceDataset(dataset)
    lengths = [int(n) for n in src.episodes.column("length").to_pylist()[: src.total]]
    drops = parse_frames(frames, lengths) if frames is not None else idle_drops(dataset, src.total, min_frames)
    subset = FrameSubset(src, kept(drops))
    details: dict[str, Any] = {"frames": {str(e): [[a, b - 1] for a, b in spans] for e, spans in drops.items()}}
    if idle:
        details["idle"] = {"min_frames": min_frames}
    try:
        result = write_edit(
            [(src, e) for e in range(src.total)],
            src.root,
            out,
            in_place,
            "trim",
            Rewrite(transform=subset.step(progress), details=details),
        )
    finally:
        subset.close()
    return result, subset.counts


def renumber_frames(text: str, numbers: Sequence[int]) -> str:
    """`--frames` typed in a LeRobot v2.x dataset's own episode numbers `numbers`, as its v3.0 upgrade numbers
    them (`episodes.renumber_list`): with numbers [29], `29:0-9` -> `0:0-9`; a malformed part left as typed."""
    if list(numbers) == list(range(len(numbers))):
        return text
    out: list[str] = []
    for part in (p.strip() for p in text.split(",")):
        m = _SPAN.fullmatch(part)
        at = position_of(int(m[1]), numbers, f"--frames: {part!r}") if m is not None else None
        out.append(part if m is None else f"{at}:{part.partition(':')[2]}")
    return ",".join(out)
