"""Fixtures of the hardware-producer tests: the SO-101 follower on a simulated Feetech bus.

The bus simulator needs lerobot's Feetech SDK (`scservo_sdk`), which LIBERO's own environment (.venv-libero, where
tests/producers/sim/test_libero.py runs) does not have: it is imported when the fixture is used, not here."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

import pytest

if TYPE_CHECKING:
    from tests.support.feetech_bus import SimulatedFeetechBus


@pytest.fixture
def so101(project: Path) -> Iterator[tuple[SimulatedFeetechBus, Path]]:
    """The SO-101 follower on a simulated bus; the manifest (returned) gets its calibration."""
    from tests.support.feetech_bus import SimulatedFeetechBus, write_so_calibration

    path = project / "robots" / "so101_follower" / "robot.yaml"
    write_so_calibration(path.parent / "calibration" / "so101_follower.json")
    with SimulatedFeetechBus(list(range(1, 7))) as bus:
        yield bus, path
