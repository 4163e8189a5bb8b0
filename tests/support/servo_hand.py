"""A person moving a leader arm on a simulated servo bus (tests/support/feetech_bus.py, dynamixel_bus.py), and a
recording through the real CLI while they do."""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from contextlib import ExitStack
from pathlib import Path
from typing import Protocol

import numpy as np
import numpy.typing as npt

from tests.support.background import Background
from tests.support.inproc import Run, run_inproc


class Shaft(Protocol):
    position: float


class ServoBus(Protocol):
    @property
    def servos(self) -> Mapping[int, Shaft]: ...


class Hand(Background):
    """Each joint of `bus` swings ±150 steps around 2048 (the middle of its range), the jaw opens and closes,
    as a thread turning the servos' shafts (torque off, as lerobot's leaders leave them)."""

    def __init__(self, bus: ServoBus) -> None:
        super().__init__()
        self.bus = bus

    def run(self) -> None:
        t0 = time.monotonic()
        while not self.stopping():
            t = time.monotonic() - t0
            for i, servo in self.bus.servos.items():
                servo.position = 2048 + 150 * math.sin(2 * math.pi * t / 2.0 + i)
            time.sleep(0.005)


def record_by_hand(leaders: Sequence[ServoBus], robot: str, out: Path, steps: int, *extra: str) -> Run:
    """`record --hal ROBOT --mode real --teleop leader` (10 fps, h264, marked success; `extra` arguments after)
    while a `Hand` moves each of the `leaders`' buses."""
    with ExitStack() as hands:
        for bus in leaders:
            hands.enter_context(Hand(bus))
        return run_inproc(
            "record", "--hal", robot, "--mode", "real", "--teleop", "leader", "--fps", "10", "--max-steps", str(steps),
            "--out", str(out), "--codec", "h264", "--operator", "success", *extra,
        )  # fmt: skip


def actions_are_reads(action: npt.ArrayLike, reads: npt.ArrayLike, atol: float = 1e-3) -> list[int]:
    """Which of a leader bus's position `reads` (one row per read, in the action's units) each `action` row is:
    every row must equal a read, in time order, each read used once. Not simply the last len(action) reads: the
    SDK re-reads after a reply it found late or garbled (lerobot's `num_read_retries`), and those reads reach
    the bus without reaching an action."""
    want, got = np.asarray(reads, dtype=np.float64), np.asarray(action, dtype=np.float64)
    found: list[int] = []
    for row in got:
        after = found[-1] + 1 if found else 0
        hits = [i for i in range(after, len(want)) if np.allclose(row, want[i], atol=atol)]
        assert hits, f"action row {len(found)} {row} is no read after read {after - 1}"
        found.append(hits[0])
    return found
