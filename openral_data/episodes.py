"""Episode selections as users type them: `0,3,5-7` (used by `convert` and `episodes`)."""

from __future__ import annotations

from openral_data.errors import EpisodeSelectionError


def parse_episodes(text: str | None, total: int, where: str = "--episodes") -> list[int]:
    """`0,3,5-7` -> [0, 3, 5, 6, 7]; None -> every episode."""
    if text is None:
        return list(range(total))
    chosen: list[int] = []
    for part in (p.strip() for p in text.split(",")):
        try:
            lo, _, hi = part.partition("-")
            first, last = int(lo), int(hi) if hi else int(lo)
        except ValueError:
            raise EpisodeSelectionError(
                f"{where}: {part!r} is not an episode index or a range a-b", code="episodes.syntax"
            ) from None
        if first > last or first < 0 or last >= total:
            raise EpisodeSelectionError(
                f"{where}: {part!r} is outside the dataset's episodes 0..{total - 1}", code="episodes.range"
            )
        chosen.extend(range(first, last + 1))
    if len(set(chosen)) != len(chosen):
        raise EpisodeSelectionError(f"{where}: an episode is listed twice", code="episodes.duplicate")
    return chosen
