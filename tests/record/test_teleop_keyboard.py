"""`record --scene tabletop_push --teleop keyboard`: a person at a terminal drives the scene.

The real CLI runs as a subprocess whose stdin, stdout and stderr are a pseudo-terminal; this test is the person:
it reads the status lines the teleop prints (where the gripper is), types keys into the pty (space to start,
i/k/j/l/u/m to move) and pushes the cube into the goal, closed loop as a person watching would. The recording
then replays exactly (`replay --mode actions`) and says who drove (`operator` in `openral.episode_info`).
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from openral_data.producers.hal.teleop.keyboard import KeyboardGains
from tests.support.pty_terminal import Terminal as PtyTerminal
from tests.support.pty_terminal import cli_on_pty
from tests.support.teleop_push import push_waypoints, pushed, replays_exactly

F64 = npt.NDArray[np.float64]
SEED = 0
STATUS = re.compile(rb"eef (-?\d+\.\d+) (-?\d+\.\d+) (-?\d+\.\d+) gripper \w+ pending (-?\d+) (-?\d+) (-?\d+) (-?\d+)")
STEP = KeyboardGains().step


class Terminal(PtyTerminal):
    """The pty, and the teleop's status lines on it."""

    def status(self, after: int) -> tuple[F64, int, int]:
        """The newest status line printed after byte `after`: (eef position, moves pending, its end)."""
        found = list(STATUS.finditer(self.text, after))
        if not found:
            return np.zeros(3), 1, after
        m = found[-1]
        pending = sum(abs(int(m.group(k))) for k in range(4, 8))
        return np.array([float(m.group(k)) for k in (1, 2, 3)]), pending, m.end()


def _drive_to(term: Terminal, target: F64, tol: float, deadline: float, running: Callable[[], bool]) -> None:
    """Type moves toward `target` whenever the last ones were made, until the status shows it reached (or the
    recording ended: the scene ends the episode when the cube is in the goal)."""
    seen = len(term.text)
    while time.monotonic() < deadline and running():
        term.read(0.05)
        pos, pending, end = term.status(seen)
        if end == seen or pending:
            continue
        seen = end
        err = target - pos
        if np.all(np.abs(err) < tol):
            return
        keys = ""
        for (plus, minus), e in zip((("i", "k"), ("j", "l"), ("u", "m")), err, strict=True):
            n = int(np.clip(round(e / STEP), -2, 2))
            keys += (plus if n > 0 else minus) * abs(n)
        term.type(keys)
    if running():
        raise AssertionError(f"never reached {target}: {term.text[-3000:].decode(errors='replace')}")


@pytest.mark.slow
def test_a_person_at_a_terminal_pushes_the_cube_and_the_episode_replays(project: Path, tmp_path: Path) -> None:
    waypoints = push_waypoints(SEED)
    out = tmp_path / "teleop"
    args = ["record", "--scene", "tabletop_push", "--teleop", "keyboard", "--out", str(out), "--codec", "h264"]
    with cli_on_pty([*args, "--seed", str(SEED), "--n-episodes", "1"], Terminal) as (proc, term):
        term.wait_for(b"press space to start", 60)
        term.type(" g")  # start, and close the gripper: closed fingers push, open ones straddle the cube
        deadline = time.monotonic() + 40
        for k, target in enumerate(waypoints):
            _drive_to(term, target, 0.008 if k == 0 else 0.012, deadline, lambda: proc.poll() is None)
        proc.wait(timeout=20)
        term.read(0.2)
    actions = pushed(out, proc.returncode, term.text, "teleop:keyboard")
    assert np.all(actions[:, 6] == 1.0)  # the gripper closed from the first frame on
    assert np.abs(actions[:, :3]).max() <= KeyboardGains().max_step + 1e-6
    assert set(np.round(actions[:, :3].ravel() / STEP, 6)) <= {-2.0, -1.0, 0.0, 1.0, 2.0}  # whole key presses
    replays_exactly(out, tmp_path / "res")
