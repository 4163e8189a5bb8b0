"""`record --scene tabletop_push --teleop keyboard`: a person at a terminal drives the scene.

The real CLI runs as a subprocess whose stdin, stdout and stderr are a pseudo-terminal; this test is the person:
it reads the status lines the teleop prints (where the gripper is), types keys into the pty (space to start,
i/k/j/l/u/m to move) and pushes the cube into the goal, closed loop as a person watching would. The recording
then replays exactly (`replay --mode actions`) and says who drove (`operator` in `openral.episode_info`).
"""

from __future__ import annotations

import json
import re
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from openral_data.policies.motion import Truth
from openral_data.producers.hal.teleop import KeyboardGains
from openral_data.runtime import registry
from openral_data.schemas.scene import load_recordable_scene
from tests.support.hal import episode_infos, frames_table
from tests.support.inproc import run_inproc
from tests.support.pty_cli import Terminal, on_pty

F64 = npt.NDArray[np.float64]
SEED = 0
STATUS = re.compile(rb"eef (-?\d+\.\d+) (-?\d+\.\d+) (-?\d+\.\d+) gripper \w+ pending (-?\d+) (-?\d+) (-?\d+) (-?\d+)")
STEP = KeyboardGains().step


def _waypoints(seed: int) -> list[F64]:
    """Where a person would put the gripper to push the cube of episode `seed` into the goal: behind the cube
    at travel height, down to pushing height, then along the line cube -> goal."""
    path = registry.resolve_scene_path("tabletop_push")
    scene = load_recordable_scene(path)
    robot, (rskill, _) = registry.ROBOTS["franka_panda"], registry.resolve_rskill("scripted-push")
    env = registry.scene_factory(scene.scene.type, str(path))(scene, robot, rskill, str(path))
    try:
        t = Truth.of(env.reset(seed))
        name = t.role("object")
        cube, goal, half = t.pos(name), t.pos(t.role("goal")), float(t.info(name)["size"][2]) / 2
    finally:
        env.close()
    direction = (goal[:2] - cube[:2]) / np.linalg.norm(goal[:2] - cube[:2])
    behind = cube[:2] - direction * (half + 0.045)  # clear of the cube by more than a step
    push_z = t.table + 0.022
    end = goal[:2] - direction * (half + 0.005)
    return [np.array([*behind, t.table + 0.1]), np.array([*behind, push_z]), np.array([*end, push_z])]


def _status(term: Terminal, after: int) -> tuple[F64, int, int]:
    """The newest status line printed after byte `after`: (eef position, moves pending, its end)."""
    found = list(STATUS.finditer(term.text, after))
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
        pos, pending, end = _status(term, seen)
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
    waypoints = _waypoints(SEED)
    out = tmp_path / "teleop"
    args = ["record", "--scene", "tabletop_push", "--teleop", "keyboard", "--out", str(out), "--codec", "h264"]
    with on_pty(*args, "--seed", str(SEED), "--n-episodes", "1") as (proc, term):
        term.wait_for(b"press space to start", 60)
        term.type(" g")  # start, and close the gripper: closed fingers push, open ones straddle the cube
        deadline = time.monotonic() + 40
        for k, target in enumerate(waypoints):
            _drive_to(term, target, 0.008 if k == 0 else 0.012, deadline, lambda: proc.poll() is None)
        proc.wait(timeout=20)
        term.read(0.2)
    text = term.text.decode(errors="replace")
    assert proc.returncode == 0, text[-2000:]
    assert "episode 0: kept (scene" in text

    cols = frames_table(out)
    assert cols["next.success"][-1] is True
    actions = np.array(cols["action"])
    assert np.all(actions[:, 6] == 1.0)  # the gripper closed from the first frame on
    assert actions.shape[1] == 7 and np.abs(actions[:, :3]).max() <= KeyboardGains().max_step + 1e-6
    assert set(np.round(actions[:, :3].ravel() / STEP, 6)) <= {-2.0, -1.0, 0.0, 1.0, 2.0}  # whole key presses
    info = episode_infos(out)[0]
    assert info["operator"] == "teleop:keyboard" and info["hal"]["verdict"] == "scene"

    res = tmp_path / "res"
    r = run_inproc("replay", str(out), "--mode", "actions", "--out", str(res), "--json")
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout)
    assert summary["diverged_episodes"] == {} and summary["divergence_max"] == 0
    assert summary["success_recorded"] == 1 and summary["success_replayed"] == 1
