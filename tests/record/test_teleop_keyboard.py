"""`record --scene tabletop_push --teleop keyboard`: a person at a terminal drives the scene.

The real CLI runs as a subprocess whose stdin, stdout and stderr are a pseudo-terminal; this test is the person:
it learns the keys from what the prompt shows (nothing else: no source, no docs), reads the status lines the
teleop prints (where the gripper is, where the cube and the goal are from it, whether the success term holds)
and pushes the cube into the goal, closed loop as a person watching would. The recording then replays exactly
(`replay --mode actions`) and says who drove (`operator` in `openral.episode_info`).
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from tests.support.pty_terminal import Terminal as PtyTerminal
from tests.support.pty_terminal import cli_on_pty
from tests.support.teleop_push import push_path, pushed, replays_exactly

F64 = npt.NDArray[np.float64]
SEED = 0
NUM = rb"([+-]?\d+\.\d+)"
STATUS = re.compile(
    rb"eef " + NUM + rb" " + NUM + rb" " + NUM + rb" gripper \w+ pending (-?\d+) (-?\d+) (-?\d+) (-?\d+)\r+\n"
    rb"  cube " + NUM + rb" " + NUM + rb" " + NUM + rb" \xc2\xb7 goal " + NUM + rb" " + NUM + rb" " + NUM
)
CUBE_HALF = 0.025  # what a person sees: a cube about 5 cm wide


class Terminal(PtyTerminal):
    """The pty, and the teleop's status lines on it."""

    def status(self, after: int) -> tuple[F64, F64, F64, int, int] | None:
        """The newest status printed after byte `after`: (gripper, cube, goal positions, moves pending, its end)."""
        found = list(STATUS.finditer(self.text, after))
        if not found:
            return None
        m = found[-1]
        eef = np.array([float(m.group(k)) for k in (1, 2, 3)])
        cube, goal = (eef + np.array([float(m.group(k)) for k in ks]) for ks in ((8, 9, 10), (11, 12, 13)))
        return eef, cube, goal, sum(abs(int(m.group(k))) for k in range(4, 8)), m.end()


def keys_from_prompt(prompt: str) -> tuple[dict[int, tuple[str, str]], str]:
    """The move keys per world axis (+ key, - key) and the gripper key, read off the prompt's key list."""
    axes = {}
    for axis, name in enumerate("xyz"):
        m = re.search(rf"(\S)/(\S)(?: \([^)]*\))? \+{name}/-{name}", prompt)
        assert m, f"the prompt does not say which keys move along {name}: {prompt}"
        axes[axis] = (m[1], m[2])
    gripper = re.search(r"(\S) gripper", prompt)
    assert gripper, prompt
    return axes, gripper[1]


def _drive(term: Terminal, proc_alive: Callable[[], bool], axes: dict[int, tuple[str, str]], step: float) -> None:
    """Closed loop on the status lines: a few presses toward the next target whenever the last ones were made."""
    seen, targets, deadline, carry = 0, None, time.monotonic() + 60, np.zeros(3)
    while time.monotonic() < deadline and proc_alive():
        term.read(0.05)
        got = term.status(seen)
        if got is None or got[4] == seen or got[3]:
            continue
        eef, cube, goal, _, seen = got
        if targets is None:  # planned once, from the first status: pushed at the cube's middle
            z = cube[2] - 0.003
            targets = push_path(cube, goal, CUBE_HALF, push_z=z, travel_z=z + 0.08)
        err = targets[0] - eef
        if np.all(np.abs(err) < (0.008 if len(targets) == 3 else 0.012)):
            targets = targets[1:] or targets
            continue
        want = err / step
        want = want * min(1.0, 2 / np.abs(want).max()) + carry  # at most 2 presses per axis, along the line
        presses = [round(float(v)) for v in want]
        carry = want - presses  # the fractions of a press left over, made up later
        term.type("".join((axes[a][0] if n > 0 else axes[a][1]) * abs(n) for a, n in enumerate(presses)))
    assert not proc_alive(), f"never pushed the cube in: {term.text[-3000:].decode(errors='replace')}"


@pytest.mark.slow
def test_a_person_at_a_terminal_pushes_the_cube_and_the_episode_replays(project: Path, tmp_path: Path) -> None:
    out = tmp_path / "teleop"
    args = ["record", "--scene", "tabletop_push", "--teleop", "keyboard", "--out", str(out), "--codec", "h264"]
    step = 0.01  # the prompt's keys move 1 cm per press (`--teleop-gain` 1)
    with cli_on_pty([*args, "--seed", str(SEED), "--n-episodes", "1"], Terminal) as (proc, term):
        _, end = term.wait_for(b"press space to start", 60)
        axes, gripper = keys_from_prompt(term.text[:end].decode())
        term.type(" " + gripper)  # start, and close the gripper: closed fingers push, open ones straddle the cube
        _drive(term, lambda: proc.poll() is None, axes, step)
        proc.wait(timeout=20)
        term.read(0.2)
    assert b"success: cube in goal no" in term.text  # the success term shown while it did not hold
    actions = pushed(out, proc.returncode, term.text, "teleop:keyboard")
    assert np.all(actions[:, 6] == 1.0)  # the gripper closed from the first frame on
    assert np.abs(actions[:, :3]).max() <= 2 * step + 1e-6  # paid out at most 2 presses per tick
    assert set(np.round(actions[:, :3].ravel() / step, 6)) <= {-2.0, -1.0, 0.0, 1.0, 2.0}  # whole presses
    replays_exactly(out, tmp_path / "res")
