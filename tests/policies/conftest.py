"""Fixtures of the lerobot policy tests: a mock recording and an ACT checkpoint lerobot's own classes make on it."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.support.checkpoint import make_act_checkpoint
from tests.support.home import isolated_home
from tests.support.replay import record_mock


@pytest.fixture(scope="module")
def mock(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[Path, Path]]:
    """A mock dataset (front 64x48 + wrist 32x32, 8-dim state, 7-dim action) and its project home."""
    base = tmp_path_factory.mktemp("mock")
    with isolated_home(base) as home:
        yield record_mock(home, base / "mock").out, home


@pytest.fixture(scope="module")
def checkpoint(mock: tuple[Path, Path], tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A freshly initialised ACT checkpoint on the dataset's features (front camera only) and stats."""
    out = tmp_path_factory.mktemp("ckpt") / "act"
    make_act_checkpoint(mock[0], out, drop=("observation.images.wrist",))
    return out
