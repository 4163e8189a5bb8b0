"""Episode selections as users type them: `0,3,5-7` (used by `convert` and `episodes`), and typed in a LeRobot
v2.x dataset's own episode numbers (`renumber_list`)."""

from __future__ import annotations

import re
from collections.abc import Sequence

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


def renumber_list(text: str, numbers: Sequence[int], where: str = "--episodes") -> str:
    """`text` (`0,3,5-7`) typed in a dataset's own episode numbers, `numbers` in order (a LeRobot v2.x dataset's
    `episode_index`, gaps allowed), as the positions 0..n-1 its v3.0 upgrade numbers them: with numbers
    [5, 7, 29], `29,5` -> `2,0`. Every number a part names must be one of `numbers`; a part that is not a number
    or an ascending range is left as typed, for `parse_episodes` to name."""
    if list(numbers) == list(range(len(numbers))):
        return text
    out: list[str] = []
    for part in (p.strip() for p in text.split(",")):
        match = _PART.fullmatch(part)
        first, last = (int(match[1]), int(match[2] or match[1])) if match is not None else (1, 0)
        if first > last:
            out.append(part)
            continue
        out.extend(str(position_of(k, numbers, f"{where}: {part!r}")) for k in range(first, last + 1))
    return ",".join(out)


def position_of(number: int, numbers: Sequence[int], where: str) -> int:
    """Where episode `number` is among a dataset's episode numbers `numbers` (see `renumber_list`)."""
    try:
        return list(numbers).index(number)
    except ValueError:
        listed = format_episodes(sorted(numbers))
        shown = listed if len(listed) <= 60 else listed[:60].rsplit(",", 1)[0] + ",…"
        raise EpisodeSelectionError(
            f"{where}: episode {number} is not one of the dataset's episodes {shown}", code="episodes.range"
        ) from None


def select_numbered(text: str | None, numbers: Sequence[int], where: str = "--episodes") -> list[int]:
    """`parse_episodes` for a dataset whose episodes are numbered `numbers` (see `renumber_list`): the positions
    of the episodes `text` names, in the order named; None -> every episode."""
    return parse_episodes(None if text is None else renumber_list(text, numbers, where), len(numbers), where)
