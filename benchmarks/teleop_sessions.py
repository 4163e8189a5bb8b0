"""People's sessions for the quality corpus: `openral-data record --scene tabletop_push --teleop gamepad=NODE`
driven through the real device path (the node a FIFO the CLI opens as its evdev device, written with raw
`struct input_event` records, as tests/record/test_teleop_devices.py does), by a scripted person.

The person reads the status lines the teleop prints on its terminal (a pty), steers the stick toward the push
waypoints of the episode's cube (tests/support/teleop_push.py) in proportion to the distance left, with a
hand's unsteadiness (a random gain and wobble per move), pauses now and then, and closes the gripper once at
the start. The episode ends at `--max-steps` whether the cube reached the goal or not .
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from openral_data.producers.hal.teleop import gamepad
from tests.support.input_devices import Gamepad
from tests.support.pty_terminal import Terminal
from tests.support.teleop_push import ended, push_waypoints

STATUS = re.compile(rb"eef (-?\d+\.\d+) (-?\d+\.\d+) (-?\d+\.\d+) gripper (open|closed)\r*\n")


def steer(pad: Gamepad, u: np.ndarray) -> None:
    """Hold deflection `u` (x forward, y left, z up, each in [-1, 1], past the deadzone)."""
    dz = gamepad.GAINS.deadzone
    x, y, z = (0.0 if v == 0 else float(np.sign(v)) * (dz + (1 - dz) * min(1.0, abs(float(v)))) for v in u)
    pad.sticks(ABS_Y=-x, ABS_X=-y, ABS_RY=-z)


def drive(pad: Gamepad, term: Terminal, proc: subprocess.Popen[bytes], seed: int) -> None:
    """One episode: toward each waypoint in turn until the recording says the episode ended."""
    rng = np.random.default_rng(seed)
    waypoints = push_waypoints(seed)
    term.wait_for(b"gripper open", 120)
    pad.press(gamepad.BTN_SOUTH)
    k, seen, episodes_done = 0, len(term.text), term.text.count(b"kept")
    gain = rng.uniform(0.6, 1.2)
    while proc.poll() is None and term.text.count(b"kept") == episodes_done:
        term.read(0.05)
        found = list(STATUS.finditer(term.text, seen))
        if not found:
            continue
        seen = found[-1].end()
        pos = np.array([float(found[-1].group(i)) for i in (1, 2, 3)])
        err = waypoints[k] - pos
        if np.all(np.abs(err) < 0.012) and k < len(waypoints) - 1:
            k += 1
            gain = rng.uniform(0.6, 1.2)
        if rng.random() < 0.03:  # a pause: the person looks at the scene
            steer(pad, np.zeros(3))
            time.sleep(rng.uniform(0.2, 0.6))
            continue
        u = np.clip(gain * err / (4 * gamepad.GAINS.linear) + rng.normal(0, 0.08, 3), -1, 1)
        steer(pad, u)


def record_sessions(out: Path, episodes: int, max_steps: int, scratch: Path, first_seed: int = 0) -> None:
    """`episodes` gamepad sessions of tabletop_push (seeds `first_seed`, `first_seed` + 1, ...) into the dataset
    `out`."""
    scratch.mkdir(parents=True, exist_ok=True)
    node = scratch / "event0"
    node.unlink(missing_ok=True)
    pad = Gamepad(node)
    master, slave = os.openpty()
    args = ["record", "--scene", "tabletop_push", "--teleop", f"gamepad={node}", "--out", str(out)]
    args += ["--codec", "h264", "--seed", str(first_seed), "--n-episodes", str(episodes), "--max-steps", str(max_steps)]
    proc = subprocess.Popen(
        [sys.executable, "-m", "openral_data.cli", *args],
        stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=slave,
        env={**os.environ, "MUJOCO_GL": "egl"}, close_fds=True,
    )  # fmt: skip
    os.close(slave)
    term = Terminal(master)
    try:
        for e in range(episodes):
            drive(pad, term, proc, first_seed + e)
        proc.wait(timeout=120)
    finally:
        ended(proc)
        os.close(master)
        pad.unplug()
    if proc.returncode != 0:
        raise RuntimeError(f"teleop sessions: {term.text[-2000:].decode(errors='replace')}")
