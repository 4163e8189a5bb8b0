"""episodes.py: the selections users type, and every way to get one wrong (the fuzzing is in tests/malformed)."""

from __future__ import annotations

import pytest

from openral_data.episodes import format_episodes, parse_episodes
from openral_data.errors import EpisodeSelectionError


def test_selections() -> None:
    assert parse_episodes("0,3,5-7", 10) == [0, 3, 5, 6, 7]
    assert parse_episodes(" 4 , 2 ", 10) == [4, 2]
    assert parse_episodes(None, 3) == [0, 1, 2]


@pytest.mark.parametrize(
    ("text", "code"),
    [
        ("1-", "episodes.syntax"),  # an open range is not `1`
        ("-1", "episodes.syntax"),
        ("", "episodes.syntax"),
        ("0,,1", "episodes.syntax"),
        ("1_0", "episodes.syntax"),
        ("\u0661", "episodes.syntax"),
        ("0-1-2", "episodes.syntax"),
        ("9" * 30, "episodes.syntax"),
        ("3-1", "episodes.range"),
        ("10", "episodes.range"),
        ("0,0", "episodes.duplicate"),
        ("0-2,1", "episodes.duplicate"),
    ],
)
def test_bad_selections(text: str, code: str) -> None:
    with pytest.raises(EpisodeSelectionError) as err:
        parse_episodes(text, 10)
    assert err.value.code == code and str(err.value).startswith("--episodes: ")


@pytest.mark.parametrize(
    ("indices", "text"),
    [([], ""), ([3], "3"), ([0, 1], "0,1"), ([0, 1, 2, 5], "0-2,5"), ([1, 3, 4, 5, 6, 9, 10], "1,3-6,9,10")],
)
def test_format_episodes_is_read_back_by_parse_episodes(indices: list[int], text: str) -> None:
    assert format_episodes(indices) == text
    if indices:
        assert parse_episodes(text, 20) == indices
