"""Where a person would move the gripper to push the cube of `tabletop_push` into the goal (the teleoperation
tests drive the real CLI through these waypoints, closed loop against its status lines)."""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

import numpy as np
import numpy.typing as npt

from openral_data.policies.motion import Truth
from openral_data.runtime import registry
from openral_data.schemas.scene import load_recordable_scene
from tests.support.hal import episode_infos, frames_table
from tests.support.inproc import run_inproc

F64 = npt.NDArray[np.float64]
# an intervention session's announcements on the terminal (policies/intervention.py): the frame a toggle took
# effect, and every few frames while the policy drives
POLICY_DRIVES = re.compile(rb"frame (\d+): policy drives \(")
TELEOP_TAKES_OVER = re.compile(rb"frame (\d+): teleop drives")
POLICY_AGAIN = re.compile(rb"frame (\d+): policy drives again")


def push_waypoints(seed: int) -> list[F64]:
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
    return push_path(cube, goal, half, push_z=t.table + 0.022, travel_z=t.table + 0.1)


def push_path(cube: F64, goal: F64, half: float, push_z: float, travel_z: float) -> list[F64]:
    """Behind the cube (seen from the goal) at `travel_z`, down to `push_z`, then along the line cube -> goal to
    where the cube's near face reaches it."""
    direction = (goal[:2] - cube[:2]) / np.linalg.norm(goal[:2] - cube[:2])
    behind = cube[:2] - direction * (half + 0.045)  # clear of the cube by more than a step
    end = goal[:2] - direction * (half + 0.005)
    return [np.array([*behind, travel_z]), np.array([*behind, push_z]), np.array([*end, push_z])]


def expert_proposals(
    actions: npt.NDArray[np.float32], seed: int, scene: str = "tabletop_push"
) -> npt.NDArray[np.float32]:
    """What the `scripted-push` expert proposes at every frame of a `tabletop_push` episode (or of `scene`, a
    variant) that executed `actions`, recomputed: the scene re-run from `seed` with those actions, the same expert
    stepped on each observation."""
    path = registry.resolve_scene_path(scene)
    scene = load_recordable_scene(path)
    robot, (rskill, rskill_path) = registry.ROBOTS["franka_panda"], registry.resolve_rskill("scripted-push")
    env = registry.scene_factory(scene.scene.type, str(path))(scene, robot, rskill, str(path))
    policy = registry.policy_factory(rskill, str(rskill_path))(rskill)
    try:
        obs = env.reset(seed)
        policy.reset(seed)
        out = []
        for action in actions:
            out.append(policy.step(obs, obs.task))
            obs = env.step(np.asarray(action, dtype=np.float32)).observation
    finally:
        env.close()
    return np.stack(out)


def replays_exactly(out: Path, res: Path, succeeded: bool = True) -> None:
    """`replay --mode actions` of the one-episode recording `out` reproduces it: no divergence; the success too
    (`succeeded`: the episode ended with the cube in the goal)."""
    r = run_inproc("replay", str(out), "--mode", "actions", "--out", str(res), "--json")
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout)
    assert summary["diverged_episodes"] == {} and summary["divergence_max"] == 0
    if succeeded:
        assert summary["success_recorded"] == 1 and summary["success_replayed"] == 1


def pushed(out: Path, returncode: int, output: bytes, driver: str) -> npt.NDArray[np.float64]:
    """The recording `out` of one teleoperated episode the scene ended with the cube in the goal, driven by
    `driver` (`openral.episode_info`'s operator); its actions."""
    text = output.decode(errors="replace")
    assert returncode == 0, text[-2000:]
    assert "episode 1/1: kept (scene" in text
    cols = frames_table(out)
    assert cols["next.success"][-1] is True
    info = episode_infos(out)[0]
    assert info["operator"] == driver and info["hal"]["verdict"] == "scene"
    actions = np.array(cols["action"], dtype=np.float64)
    assert actions.shape[1] == 7
    return actions


def ended(proc: subprocess.Popen[bytes]) -> None:
    """The recording process is gone: killed if it still runs (a test that failed half-way)."""
    if proc.poll() is None:
        proc.kill()
        proc.wait()
