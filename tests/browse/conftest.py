"""The dataset the browse tests look at: lerobot 0.6.1's own output (three episodes of 6, 9, 4 frames; camera
frames a flat grey of 10 * t, so each frame is told from its neighbours; episode 1 failed)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.support.lerobot_written import write_lerobot_dataset


@pytest.fixture(scope="session")
def browse_dataset(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("browse") / "ds"
    write_lerobot_dataset(root, True)
    return root
