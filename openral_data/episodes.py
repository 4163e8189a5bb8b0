"""Episode selections as users type them: `0,3,5-7` (used by `convert` and `episodes`)."""

from __future__ import annotations

import re

from openral_data.errors import EpisodeSelectionError

_PART = re.compile(r"([0-9]{1,18})(?:-([0-9]{1,18}))?")  # ASCII digits only: no `1_0`, no other scripts' digits


def parse_episodes(text: str | None, total: int, where: str = "--episodes") -> list[int]:
    """`0,3,5-7` -> [0, 3, 5, 6, 7]; None -> every episode. An open range (`1-`, `-3`) is an error."""
    if text is None:
        return list(range(total))
    chosen: list[int] = []
    for part in (p.strip() for p in text.split(",")):
        match = _PART.fullmatch(part)
        if match is None:
            raise EpisodeSelectionError(
                f"{where}: {part!r} is not an episode index or a range a-b", code="episodes.syntax"
            )
        first = int(match[1])
        last = int(match[2]) if match[2] is not None else first
        if first > last or first < 0 or last >= total:
            raise EpisodeSelectionError(
                f"{where}: {part!r} is outside the dataset's episodes 0..{total - 1}", code="episodes.range"
            )
        chosen.extend(range(first, last + 1))
    if len(set(chosen)) != len(chosen):
        raise EpisodeSelectionError(f"{where}: an episode is listed twice", code="episodes.duplicate")
    return chosen


def format_episodes(indices: list[int]) -> str:
    """Ascending indices as `parse_episodes` reads them, runs of three or more as ranges: [0, 1, 2, 5] -> "0-2,5"."""
    parts: list[str] = []
    k = 0
    while k < len(indices):
        j = k
        while j + 1 < len(indices) and indices[j + 1] == indices[j] + 1:
            j += 1
        if j - k >= 2:
            parts.append(f"{indices[k]}-{indices[j]}")
        else:
            parts.extend(str(i) for i in indices[k : j + 1])
        k = j + 1
    return ",".join(parts)
