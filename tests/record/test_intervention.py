"""An intervention session: `record --scene tabletop_push --rskill scripted-push --teleop keyboard`.

First the latency, exactly: the fixed-rate loop on the UR5e twin with the real `KeyboardOperator` reading a
pty, the person typing `t` into it while frame k is being worked on: frame k+1 is the first one the teleoperator
drives (and the first the policy drives again after the second `t`), and a plain recording has no such column.

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
import os
import re
from pathlib import Path

import numpy as np
import pytest

from openral_data.columns import INTERVENTION, POLICY_ACTION
from openral_data.metrics.command import stats_query
from openral_data.policies.intervention import (
    Intervention,
    TakeoverSwitch,
    intervention_columns,
)
from openral_data.producers.hal.session.operator import KeyboardOperator
from openral_data.producers.hal.teleop.keyboard import KeyboardGains
from openral_data.record.hal import HalRecordOptions, record_hal
from openral_data.record.hal_loop import EpisodeEnd
from openral_data.runtime import registry
from openral_data.types import Observation
from tests.support.hal import episode_infos, frames_table, run_loop, ur5e_twin
from tests.support.pty_terminal import Terminal, cli_on_pty
from tests.support.teleop_push import (
    POLICY_AGAIN,
    POLICY_DRIVES,
    TELEOP_TAKES_OVER,
    expert_proposals,
    replays_exactly,
)

SEED = 0
STEPS = 70
STATUS = re.compile(rb"eef -?\d+\.\d+ -?\d+\.\d+ -?\d+\.\d+ gripper \w+ pending 0 0 0 0")


class _Hold:
    """A joint teleoperator that holds the action in effect at the takeover (what it was given by `take_over`)."""

    def __init__(self) -> None:
        self.held: np.ndarray | None = None  # type: ignore[type-arg]

    def take_over(self, action: np.ndarray) -> None:  # type: ignore[type-arg]
        self.held = action.copy()

    def reset(self, seed: int) -> None:
        self.held = None

    def step(self, observation: Observation, instruction: str) -> np.ndarray:  # type: ignore[type-arg]
        assert self.held is not None
        return self.held

    def close(self) -> None:
        pass


class _Person:
    """The sweep policy, and a person who types `t` into the terminal while frame k in `presses` is worked on;
    it keeps every proposal."""

    def __init__(self, master: int, presses: set[int]) -> None:
        rskill, path = registry.resolve_rskill("sweep-ur5e")
        self.inner = registry.policy_factory(rskill, str(path))(rskill)
        self.master, self.presses = master, presses
        self.proposals: list[np.ndarray] = []  # type: ignore[type-arg]

    def reset(self, seed: int) -> None:
        self.inner.reset(seed)

    def step(self, observation: Observation, instruction: str) -> np.ndarray:  # type: ignore[type-arg]
        if len(self.proposals) in self.presses:
            os.write(self.master, b"t")
        self.proposals.append(self.inner.step(observation, instruction))
        return self.proposals[-1]

    def close(self) -> None:
        self.inner.close()


def test_a_press_takes_effect_at_the_next_frame(tmp_path: Path) -> None:
    rskill, _ = registry.resolve_rskill("sweep-ur5e")
    master, slave = os.openpty()
    switch = TakeoverSwitch()
    operator = KeyboardOperator(fd=slave, listener=switch.feed)
    person, hold = _Person(master, {4, 11}), _Hold()
    policy = Intervention(person, hold, switch)
    columns = intervention_columns(rskill.action_contract.names)
    os.write(master, b" ")  # space: start the episode
    try:
        [(end, rep)] = run_loop(ur5e_twin(cameras=[]), policy, operator, tmp_path / "ds", max_steps=16, columns=columns)
    finally:
        operator.close()
        os.close(master)
        os.close(slave)
    assert end is EpisodeEnd.KEPT and rep.frames == 16
    cols = frames_table(tmp_path / "ds")
    flags = cols[INTERVENTION]
    assert flags == [5 <= i < 12 for i in range(16)]
    proposals = np.array(cols[POLICY_ACTION], dtype=np.float32)
    assert np.array_equal(proposals, np.stack(person.proposals))  # what the policy proposed, every frame
    actions = np.array(cols["action"], dtype=np.float32)
    assert np.array_equal(actions[5:12], np.repeat(proposals[4:5], 7, axis=0))  # held from the takeover on

    plain = tmp_path / "plain"  # no takeover: the schema has no intervention column
    record_hal(HalRecordOptions(robot="ur5e", rskill="sweep-ur5e", max_steps=3, out=plain, codec="h264"))
    features = json.loads((plain / "meta" / "info.json").read_text())["features"]
    assert not {INTERVENTION, POLICY_ACTION} & set(features)


def _session(out: Path) -> tuple[int, int, int, str]:
    """Record one episode; (the last frame seen before `t`, the takeover frame, the hand-back frame, output)."""
    args = ["record", "--scene", "tabletop_push", "--rskill", "scripted-push", "--teleop", "keyboard"]
    more = ["--out", str(out), "--codec", "h264", "--seed", str(SEED), "--n-episodes", "1", "--max-steps", str(STEPS)]
    with cli_on_pty([*args, *more], Terminal) as (proc, term):
        term.wait_for(b"press space to start", 60)
        term.type(" ")
        seen = term.search(POLICY_DRIVES, 0, 30)
        while int(seen.group(1)) < 8:
            seen = term.search(POLICY_DRIVES, seen.end(), 30)
        term.type("t")
        taken = term.search(TELEOP_TAKES_OVER, seen.end(), 30)
        term.type("uu")  # two presses up: 0.02 m of z, paid out over the next tick(s)
        settled = term.search(STATUS, taken.end(), 30)  # the moves were made
        settled = term.search(STATUS, settled.end(), 30)
        term.type("t")
        back = term.search(POLICY_AGAIN, settled.end(), 30)
        proc.wait(timeout=60)
        term.read(0.2)
    text = term.text.decode(errors="replace")
    assert proc.returncode == 0, text[-2000:]
    return int(seen.group(1)), int(taken.group(1)), int(back.group(1)), text


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
    np.testing.assert_allclose(expert_proposals(actions, SEED), proposals, rtol=0, atol=1e-6)

    info = episode_infos(out)[0]
    assert info["operator"] == "script:scripted-push+teleop:keyboard"
    rows = stats_query([out], "SELECT * FROM intervention_episodes").records()
    assert [(r["frames"], r["intervention_frames"], r["interventions"], r["max_length"]) for r in rows] == [
        (n, end - start, 1, end - start)
    ]
    assert stats_query([out], "SELECT start_frame, end_frame FROM interventions").records() == [
        {"start_frame": start, "end_frame": end}
    ]

    replays_exactly(out, tmp_path / "res", succeeded=False)
