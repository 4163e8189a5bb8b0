"""Fixtures of the hardware-producer tests: the SO-101 follower on a simulated Feetech bus."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from tests.support.feetech_bus import SimulatedFeetechBus, write_so_calibration


@pytest.fixture
def so101(project: Path) -> Iterator[tuple[SimulatedFeetechBus, Path]]:
    """The SO-101 follower on a simulated bus; the manifest (returned) gets its calibration."""
    path = project / "robots" / "so101_follower" / "robot.yaml"
    write_so_calibration(path.parent / "calibration" / "so101_follower.json")
    with SimulatedFeetechBus(list(range(1, 7))) as bus:
        yield bus, path
