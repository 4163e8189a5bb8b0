"""An intervention session: `record --scene tabletop_push --rskill scripted-push --teleop keyboard`.

The real CLI runs on a pseudo-terminal; the scripted expert drives; this test is the person: it watches the
`frame N: policy drives` lines, presses `t` after a known frame, moves the arm up with keys while it drives, and
presses `t` again. The recording must then say at every frame who drove (exactly the frames between the two
announced toggles, each at or after the next tick following the press), store the policy's proposal at every
frame (recomputed here by stepping the same expert on a re-run of the scene with the recorded actions), store
the executed action equal to it while the policy drove, replay exactly (`replay --mode actions`), and show the
right numbers in `stats`.
"""

from __future__ import annotations

import json
import re
import time
from pathlib import Path

import numpy as np
import pytest

from openral_data.metrics.command import stats_query
from openral_data.policies.intervention import INTERVENTION, POLICY_ACTION
from openral_data.producers.hal.teleop import KeyboardGains
from openral_data.runtime import registry
from openral_data.schemas.scene import load_recordable_scene
from tests.support.hal import episode_infos, frames_table
from tests.support.inproc import run_inproc
from tests.support.pty_cli import Terminal, on_pty

SEED = 0
STEPS = 70
POLICY = re.compile(rb"frame (\d+): policy drives \(")
TAKEN = re.compile(rb"frame (\d+): teleop drives")
BACK = re.compile(rb"frame (\d+): policy drives again")
STATUS = re.compile(rb"eef -?\d+\.\d+ -?\d+\.\d+ -?\d+\.\d+ gripper \w+ pending 0 0 0 0")


def _wait(term: Terminal, pattern: re.Pattern[bytes], after: int, timeout: float) -> re.Match[bytes]:
    end = time.monotonic() + timeout
    while True:
        found = pattern.search(term.text, after)
        if found is not None:
            return found
        assert time.monotonic() < end, term.text[-2000:].decode(errors="replace")
        term.read(0.05)


def _session(out: Path) -> tuple[int, int, int, str]:
    """Record one episode; (the last frame seen before `t`, the takeover frame, the hand-back frame, output)."""
    args = ["record", "--scene", "tabletop_push", "--rskill", "scripted-push", "--teleop", "keyboard"]
    more = ["--out", str(out), "--codec", "h264", "--seed", str(SEED), "--n-episodes", "1", "--max-steps", str(STEPS)]
    with on_pty(*args, *more) as (proc, term):
        term.wait_for(b"press space to start", 60)
        term.type(" ")
        seen = _wait(term, POLICY, 0, 30)
        while int(seen.group(1)) < 8:
            seen = _wait(term, POLICY, seen.end(), 30)
        term.type("t")
        taken = _wait(term, TAKEN, seen.end(), 30)
        term.type("uu")  # two presses up: 0.02 m of z, paid out over the next tick(s)
        settled = _wait(term, STATUS, taken.end(), 30)  # the moves were made
        settled = _wait(term, STATUS, settled.end(), 30)
        term.type("t")
        back = _wait(term, BACK, settled.end(), 30)
        proc.wait(timeout=60)
        term.read(0.2)
    text = term.text.decode(errors="replace")
    assert proc.returncode == 0, text[-2000:]
    return int(seen.group(1)), int(taken.group(1)), int(back.group(1)), text


def _proposals(actions: np.ndarray) -> np.ndarray:  # type: ignore[type-arg]
    """The expert's proposal at every frame, recomputed: the scene re-run from the seed with the recorded
    (executed) actions, the same expert stepped on each observation."""
    path = registry.resolve_scene_path("tabletop_push")
    scene = load_recordable_scene(path)
    robot, (rskill, rskill_path) = registry.ROBOTS["franka_panda"], registry.resolve_rskill("scripted-push")
    env = registry.scene_factory(scene.scene.type, str(path))(scene, robot, rskill, str(path))
    policy = registry.policy_factory(rskill, str(rskill_path))(rskill)
    try:
        obs = env.reset(SEED)
        policy.reset(SEED)
        out = []
        for action in actions:
            out.append(policy.step(obs, obs.task))
            obs = env.step(np.asarray(action, dtype=np.float32)).observation
    finally:
        env.close()
    return np.stack(out)


@pytest.mark.slow
def test_a_person_takes_over_from_the_policy_and_hands_back(project: Path, tmp_path: Path) -> None:
    out = tmp_path / "interv"
    seen, start, end, text = _session(out)
    assert seen < start < end, text[-2000:]  # a press counts from the first tick after it, never before

    cols = frames_table(out)
    flags = np.array(cols[INTERVENTION])
    n = len(flags)
    assert end < n <= STEPS and flags.dtype == bool  # the step limit, or the cube reached the goal
    assert flags.tolist() == [start <= i < end for i in range(n)]  # exactly the frames between the toggles
    actions, proposals = np.array(cols["action"], dtype=np.float32), np.array(cols[POLICY_ACTION], dtype=np.float32)
    assert proposals.shape == actions.shape == (n, 7)
    assert np.array_equal(actions[~flags], proposals[~flags])  # the policy drove: its proposal was executed
    taken = actions[start:end]
    step = KeyboardGains().step
    assert np.allclose(taken[:, [0, 1, 3, 4, 5]], 0) and np.isclose(taken[:, 2].sum(), 2 * step)  # the keys typed
    assert np.all(taken[:, 6] == actions[start - 1, 6])  # the gripper stays as the policy held it: no jump
    assert not np.array_equal(taken, proposals[start:end])  # the policy kept proposing its own moves meanwhile
    np.testing.assert_allclose(_proposals(actions), proposals, rtol=0, atol=1e-6)

    info = episode_infos(out)[0]
    assert info["operator"] == "policy:scripted-push+teleop:keyboard"
    rows = stats_query([out], "SELECT * FROM intervention_episodes").records()
    assert [(r["frames"], r["intervention_frames"], r["interventions"], r["max_length"]) for r in rows] == [
        (n, end - start, 1, end - start)
    ]
    assert stats_query([out], "SELECT start_frame, end_frame FROM interventions").records() == [
        {"start_frame": start, "end_frame": end}
    ]

    r = run_inproc("replay", str(out), "--mode", "actions", "--out", str(tmp_path / "res"), "--json")
    assert r.returncode == 0, r.stderr
    summary = json.loads(r.stdout)
    assert summary["diverged_episodes"] == {} and summary["divergence_max"] == 0
