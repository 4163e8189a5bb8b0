"""Interventions with a gamepad or a SpaceMouse: `record --scene tabletop_push --rskill scripted-push --teleop
gamepad=NODE | spacemouse=NODE`: the expert drives, the device's takeover button (gamepad: RB, the right
shoulder; SpaceMouse: the right button) hands control to the person and back.

No device here: the node the real CLI opens is a FIFO the test writes what the kernel would (evdev records,
hidraw reports; tests/support/input_devices.py). First the latency, exactly: the fixed-rate loop on the UR5e
twin with the real `DeviceOperator`, the person pressing the button while frame k is being worked on (and the
reader thread having applied it): frame k+1 is the first one the device drives, and the first the policy drives
again after the second press. Then the real CLI on a pty: the test holds a deflection, presses the button after
a known frame, waits for a few frames and presses again; every frame must say who drove (exactly the frames
between the announced toggles, after the press), the executed actions on the person's frames must be the
device's (recomputed here from the raw values written and the documented gains and deadzones), the policy's
proposals the expert's (recomputed by stepping it on a re-run of the scene), and `stats`, the SQL views and
`replay --mode actions` must agree.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import numpy.typing as npt
import pytest

from openral_data.columns import INTERVENTION, POLICY_ACTION
from openral_data.errors import UsageError
from openral_data.metrics.command import stats_query
from openral_data.policies.intervention import (
    Intervention,
    device_switch,
    intervention_columns,
)
from openral_data.producers.hal.session.operator import Command, ScriptedOperator
from openral_data.producers.hal.teleop import gamepad, spacemouse
from openral_data.producers.hal.teleop.eef_device import DeviceOperator, DeviceTeleop
from openral_data.record.hal import HalRecordOptions
from openral_data.record.hal_loop import EpisodeEnd
from openral_data.runtime import registry
from openral_data.types import Observation
from tests.support.hal import episode_infos, frames_table, run_loop, ur5e_twin
from tests.support.inproc import run_inproc
from tests.support.input_devices import DeviceFifo, Gamepad, hid_axes, hid_buttons, settle
from tests.support.pty_terminal import Terminal, cli_on_pty
from tests.support.teleop_push import (
    POLICY_AGAIN,
    POLICY_DRIVES,
    TELEOP_TAKES_OVER,
    expert_proposals,
    replays_exactly,
)

F32 = npt.NDArray[np.float32]
SEED = 0
STEPS = 100  # 5 s at 20 fps: room for a loaded machine between the two presses
STATUS = re.compile(rb"eef -?\d+\.\d+ -?\d+\.\d+ -?\d+\.\d+ gripper \w+")
STICK_MAX, TRIGGER_MAX = 32767, 255
# what the person holds: gamepad left stick forward 0.6, right 0.4, right stick down 0.3, right trigger 200/255;
# SpaceMouse cap away 120, left 200, lifted 80 counts, turned counter-clockwise 150
PAD = {"ABS_Y": -0.6, "ABS_X": 0.4, "ABS_RY": 0.3}
PAD_TRIGGER = 200
CAP_T, CAP_RZ = (-200, -120, -80), -150  # raw tx, ty, tz and rz


def _device(kind: str, path: Path) -> DeviceFifo:
    return Gamepad(path) if kind == "gamepad" else DeviceFifo(path, packets=True)


def _press_takeover(fifo: DeviceFifo) -> None:
    """Press and release the takeover button: two reports."""
    if isinstance(fifo, Gamepad):
        fifo.press(gamepad.BTN_TR)
    else:
        fifo.write(hid_buttons(0b10))
        fifo.write(hid_buttons(0b00))


def _hold(fifo: DeviceFifo) -> int:
    """Deflect the device as `PAD` / `CAP_*` say; the reports written."""
    if isinstance(fifo, Gamepad):
        fifo.sticks(**PAD)
        fifo.trigger("ABS_RZ", PAD_TRIGGER)
    else:
        fifo.write(hid_axes(1, *CAP_T))
        fifo.write(hid_axes(2, 0, 0, CAP_RZ))
    return 2


def _shape(u: float, deadzone: float) -> float:
    """docs/record-your-robot.md: |u| up to the deadzone reads 0, the rest rescaled linearly to 1."""
    return 0.0 if abs(u) <= deadzone else float(np.sign(u)) * (abs(u) - deadzone) / (1 - deadzone)


def _held_action(kind: str, gripper: float) -> F32:
    """The action the held deflection makes, from the raw values written and the documented gains: [dx, dy, dz,
    0, 0, dyaw, gripper], clipped to scripted-push's bounds."""
    if kind == "gamepad":
        g = gamepad.GAINS
        stick = {name: _shape((round(v * STICK_MAX) + 0.5) / 32767.5, g.deadzone) for name, v in PAD.items()}
        yaw = _shape(PAD_TRIGGER / TRIGGER_MAX, g.deadzone)  # right trigger: counter-clockwise
        motion = [-stick["ABS_Y"], -stick["ABS_X"], -stick["ABS_RY"], yaw]
    else:
        g = spacemouse.GAINS
        tx, ty, tz = (_shape(v / spacemouse.FULL_SCALE, g.deadzone) for v in CAP_T)
        motion = [-ty, -tx, -tz, -_shape(CAP_RZ / spacemouse.FULL_SCALE, g.deadzone)]
    action = np.array([*(m * g.linear for m in motion[:3]), 0.0, 0.0, motion[3] * g.yaw, gripper])
    rskill, _ = registry.resolve_rskill("scripted-push")
    low, high = rskill.action_contract.low, rskill.action_contract.high
    assert low is not None and high is not None
    return np.clip(action, low, high).astype(np.float32)


class _Person:
    """The sweep policy, and a person who presses the takeover button while frame k in `presses` is worked on
    (and waits until the reader thread has applied it); it keeps every proposal."""

    def __init__(self, fifo: DeviceFifo, teleop: DeviceTeleop, presses: set[int]) -> None:
        rskill, path = registry.resolve_rskill("sweep-ur5e")
        self.inner = registry.policy_factory(rskill, str(path))(rskill)
        self.fifo, self.teleop, self.presses = fifo, teleop, presses
        self.proposals: list[F32] = []

    def reset(self, seed: int) -> None:
        self.inner.reset(seed)

    def step(self, observation: Observation, instruction: str) -> F32:
        if len(self.proposals) in self.presses:
            applied = self.teleop.reader.reports + 2
            _press_takeover(self.fifo)
            settle(self.teleop.reader, applied)
        self.proposals.append(self.inner.step(observation, instruction))
        return self.proposals[-1]

    def close(self) -> None:
        self.inner.close()


@pytest.mark.parametrize("kind", ["gamepad", "spacemouse"])
def test_a_button_press_takes_effect_at_the_next_frame(kind: str, tmp_path: Path) -> None:
    rskill, _ = registry.resolve_rskill("sweep-ur5e")
    fifo = _device(kind, tmp_path / "node")
    reader = (
        gamepad.open_gamepad(fifo.path) if kind == "gamepad" else spacemouse.open_spacemouse(fifo.path, takeover=True)
    )
    unbounded = (np.full(7, -np.inf), np.full(7, np.inf))
    teleop = DeviceTeleop(reader, unbounded, gamepad.GAINS if kind == "gamepad" else spacemouse.GAINS)
    switch = device_switch(teleop, "the button")
    person = _Person(fifo, teleop, {4, 11})
    operator = DeviceOperator(ScriptedOperator(), teleop)
    columns = intervention_columns(rskill.action_contract.names)
    try:
        [(end, rep)] = run_loop(
            ur5e_twin(cameras=[]), Intervention(person, teleop, switch), operator, tmp_path / "ds", max_steps=16,
            columns=columns,
        )  # fmt: skip
    finally:
        teleop.close()
        fifo.unplug()
    assert end is EpisodeEnd.KEPT and rep.frames == 16  # the button took over: no verdict (a SpaceMouse's success)
    cols = frames_table(tmp_path / "ds")
    assert cols[INTERVENTION] == [5 <= i < 12 for i in range(16)]
    assert np.array_equal(np.array(cols[POLICY_ACTION], dtype=np.float32), np.stack(person.proposals))


@pytest.mark.parametrize("kind", ["gamepad", "spacemouse"])
def test_without_a_policy_the_button_is_what_it_was(kind: str, tmp_path: Path) -> None:
    """Plain device teleoperation: the gamepad's RB does nothing, the SpaceMouse's right button marks success."""
    fifo = _device(kind, tmp_path / "node")
    reader = gamepad.open_gamepad(fifo.path) if kind == "gamepad" else spacemouse.open_spacemouse(fifo.path)
    teleop = DeviceTeleop(reader, (np.full(7, -np.inf), np.full(7, np.inf)), gamepad.GAINS)
    try:
        _press_takeover(fifo)
        settle(reader, 2)
        assert teleop.command() == (None if kind == "gamepad" else Command.SUCCESS) and teleop.gripper == 0.0
    finally:
        teleop.close()
        fifo.unplug()


def _session(kind: str, fifo: DeviceFifo, out: Path) -> tuple[int, int, int, str]:
    """Record one episode with the deflection held from the start; (the last frame seen before the press, the
    takeover frame, the hand-back frame, output)."""
    _hold(fifo)  # read by the CLI as soon as it opens the node; it only drives once the person took over
    args = ["record", "--scene", "tabletop_push", "--rskill", "scripted-push", "--teleop", f"{kind}={fifo.path}"]
    more = ["--out", str(out), "--codec", "h264", "--seed", str(SEED), "--n-episodes", "1", "--max-steps", str(STEPS)]
    with cli_on_pty([*args, *more], Terminal) as (proc, term):
        seen = term.search(POLICY_DRIVES, 0, 60)
        while int(seen.group(1)) < 8:
            seen = term.search(POLICY_DRIVES, seen.end(), 30)
        _press_takeover(fifo)
        taken = term.search(TELEOP_TAKES_OVER, seen.end(), 30)
        settled = term.search(STATUS, taken.end(), 30)  # the device drives: its status lines, every 2 frames
        settled = term.search(STATUS, settled.end(), 30)
        _press_takeover(fifo)
        back = term.search(POLICY_AGAIN, settled.end(), 30)
        proc.wait(timeout=60)
        term.read(0.2)
    fifo.unplug()
    text = term.text.decode(errors="replace")
    assert proc.returncode == 0, text[-2000:]
    return int(seen.group(1)), int(taken.group(1)), int(back.group(1)), text


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["gamepad", "spacemouse"])
def test_a_person_takes_over_with_the_device_button_and_hands_back(kind: str, project: Path, tmp_path: Path) -> None:
    out, fifo = tmp_path / "interv", _device(kind, tmp_path / "node")
    seen, start, end, text = _session(kind, fifo, out)
    assert seen < start < end, text[-2000:]  # a press counts from the first tick after it, never before
    control = gamepad.TAKEOVER_CONTROL if kind == "gamepad" else spacemouse.TAKEOVER_CONTROL
    assert f"takeover: {control} hands control to you and back" in text

    cols = frames_table(out)
    flags = np.array(cols[INTERVENTION])
    n = len(flags)
    assert end < n <= STEPS and flags.dtype == bool
    assert flags.tolist() == [start <= i < end for i in range(n)]  # exactly the frames between the toggles
    actions, proposals = np.array(cols["action"], dtype=np.float32), np.array(cols[POLICY_ACTION], dtype=np.float32)
    assert np.array_equal(actions[~flags], proposals[~flags])  # the policy drove: its proposal was executed
    held = _held_action(kind, 1.0 if actions[start - 1, 6] >= 0.5 else 0.0)  # the gripper as the policy had it
    np.testing.assert_allclose(actions[start:end], np.repeat(held[None], end - start, axis=0), rtol=0, atol=1e-7)
    np.testing.assert_allclose(expert_proposals(actions, SEED), proposals, rtol=0, atol=1e-6)

    assert episode_infos(out)[0]["operator"] == f"script:scripted-push+teleop:{kind}"
    rows = stats_query([out], "SELECT * FROM intervention_episodes").records()
    assert [(r["frames"], r["intervention_frames"], r["interventions"], r["max_length"]) for r in rows] == [
        (n, end - start, 1, end - start)
    ]
    assert stats_query([out], "SELECT start_frame, end_frame FROM interventions").records() == [
        {"start_frame": start, "end_frame": end}
    ]
    r = run_inproc("stats", str(out), "--format", "json")  # the report, through the CLI
    assert r.returncode == 0, r.stderr
    report = json.loads(r.stdout)
    [episode] = report["interventions"]
    assert (episode["frames"], episode["intervention_frames"], episode["interventions"]) == (n, end - start, 1)
    assert episode["rate"] == pytest.approx((end - start) / n) and episode["max_length"] == end - start
    [policy] = report["intervention_policies"]
    assert (policy["policy"], policy["mean_length"]) == ("scripted-push", end - start)
    replays_exactly(out, tmp_path / "res", succeeded=bool(cols["next.success"][-1]))


def test_takeover_needs_a_device_that_can(project: Path, tmp_path: Path) -> None:
    """A leader arm without --hal stays refused as before; a joint-space policy cannot be taken over with a
    device that drives the end effector; the options refuse a takeover with a leader: one line each, nothing
    written."""
    out = tmp_path / "out"
    r = run_inproc(
        "record", "--scene", "tabletop_push", "--rskill", "scripted-push", "--teleop", "leader", "--out", str(out)
    )
    assert (r.returncode, r.stderr.splitlines()) == (
        2,
        ["error: --teleop leader: needs --hal ROBOT_ID (the robot whose manifest names the leader)"],
    )
    r = run_inproc(
        "record", "--hal", "ur5e", "--rskill", "sweep-ur5e", "--teleop", f"gamepad={tmp_path}/node", "--out", str(out)
    )
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert "action_contract.representation: gamepad teleoperation drives delta_eef_gripper" in r.stderr
    assert not out.exists()
    with pytest.raises(UsageError, match=r"^interventions: a policy"):
        HalRecordOptions(robot="so101", rskill="sweep-ur5e", teleop="leader", takeover=True)
