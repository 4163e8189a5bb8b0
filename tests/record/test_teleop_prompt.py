"""What a person at the controls is told: the keys in `record --help` and at the prompt, a status line that says
where the scene's objects are from the gripper and whether the success term holds (true of the real scene), and
`--teleop-gain` scaling what one press does (and refused where it means nothing)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from openral_data.producers.hal.teleop.declare import DeviceRequest
from openral_data.producers.hal.teleop.keyboard import KeyboardGains, KeyboardTeleop, open_keyboard
from openral_data.runtime import registry
from openral_data.schemas.scene import load_recordable_scene
from openral_data.types import Observation
from tests.support.inproc import run_inproc

SCENE_LINE = re.compile(
    r"cube ([+-]\d\.\d{3}) ([+-]\d\.\d{3}) ([+-]\d\.\d{3}) · goal [+-]\d\.\d{3} [+-]\d\.\d{3} [+-]\d\.\d{3} · "
    r"success: cube in goal (yes|no)"
)


def test_record_help_names_every_teleop_key() -> None:
    r = run_inproc("record", "--help")
    text = " ".join(r.stdout.replace("│", " ").split())
    for keys in ("i/k", "+x/-x", "j/l", "+y/-y", "u/m", "+z/-z", "g gripper", "space starts", "s success", "q quit"):
        assert keys in text, keys


def test_the_status_line_says_where_the_cube_is_and_when_it_is_in_the_goal(project: Path) -> None:
    """The scripted expert pushes the cube in; the keyboard's status lines along the way are true of the scene:
    the cube's offset from the gripper is the cube's position minus the gripper's, and success flips to yes
    exactly when the scene says so."""
    path = registry.resolve_scene_path("tabletop_push")
    scene = load_recordable_scene(path)
    robot, (rskill, rskill_path) = registry.ROBOTS["franka_panda"], registry.resolve_rskill("scripted-push")
    env = registry.scene_factory(scene.scene.type, str(path))(scene, robot, rskill, str(path))
    expert = registry.policy_factory(rskill, str(rskill_path))(rskill)
    shown: list[str] = []
    keyboard = KeyboardTeleop(rskill, "scripted-push", KeyboardGains(status_every=1), shown.append)
    try:
        obs: Observation = env.reset(0)
        expert.reset(0)
        answers, truth = [], False  # (what the status line said, what the scene says) per observation
        for _ in range(250):
            keyboard.step(obs, obs.task)
            m = SCENE_LINE.search(shown[-1])
            assert m, shown[-1]
            p = obs.privileged
            cube = np.asarray(p["objects"]["cube"]["pos"]) - np.asarray(p["ee_pos"])
            assert np.allclose([float(m[k]) for k in (1, 2, 3)], cube, atol=6e-4)
            answers.append((m[4] == "yes", truth))
            if truth:
                break
            step = env.step(expert.step(obs, obs.task))
            obs, truth = step.observation, step.success
    finally:
        env.close()
    assert answers[0] == (False, False) and answers[-1] == (True, True)
    assert all(said == true for said, true in answers)


def test_teleop_gain_scales_a_press(project: Path) -> None:
    rskill = registry.resolve_rskill("scripted-push")[0]
    moved = []
    for gain in (1.0, 2.5):
        keyboard = open_keyboard(DeviceRequest(None, rskill, "scripted-push", gain=gain))
        keyboard.feed("i")
        obs = Observation(state=np.zeros(8, dtype=np.float32), images={}, task="", time=0.0)
        moved.append(float(keyboard.step(obs, "")[0]))
    assert moved == pytest.approx([0.01, 0.025])


@pytest.mark.parametrize(
    ("extra", "said"),
    [
        (["--teleop", "keyboard", "--teleop-gain", "0"], "error: --teleop-gain: 0: a number in 0.1..10"),
        (["--rskill", "scripted-push", "--teleop-gain", "2"], "error: --teleop-gain: only with --hal ROBOT_ID or"),
    ],
)
def test_a_teleop_gain_that_means_nothing_is_one_line(
    project: Path, tmp_path: Path, extra: list[str], said: str
) -> None:
    out = tmp_path / "o"
    r = run_inproc("record", "--scene", "tabletop_push", *extra, "--out", str(out))
    assert r.returncode == 2 and r.stderr.startswith(said) and len(r.stderr.splitlines()) == 1, r.stderr
    assert not out.exists()
