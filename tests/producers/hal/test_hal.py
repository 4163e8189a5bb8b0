"""HAL protocol, safety filter and operator controls, on the real MuJoCo twin of the UR5e manifest."""

from __future__ import annotations

import os
import time

import numpy as np
import pytest

# ConfigError raises are matched by message on purpose: the file and field it names are the point
from openral_data.errors import ConfigError, EstopLatched, HalError, StaleState, UsageError
from openral_data.producers.hal.robots.base import JointCommand, RobotState
from openral_data.producers.hal.robots.safety import SafetyFilter
from openral_data.producers.hal.robots.twin import MujocoTwinHal
from openral_data.producers.hal.session.operator import Command, KeyboardOperator, ScriptedOperator, parse_script
from openral_data.runtime import registry
from openral_data.schemas.hal import SafetyConfig, Workspace
from tests.support.hal import ur5e_twin


@pytest.fixture(scope="module")
def twin() -> MujocoTwinHal:
    return ur5e_twin(cameras=[])


def test_connect_and_disconnect_are_idempotent(twin: MujocoTwinHal) -> None:
    with pytest.raises(HalError) as excinfo:
        twin.read_state()
    assert excinfo.value.code == "hal.disconnected"
    twin.connect()
    twin.connect()
    state = twin.read_state()
    assert state.positions.dtype == np.float32 and state.positions.shape == (7,)
    assert np.allclose(state.positions[:6], twin.home, atol=1e-3)
    twin.disconnect()
    twin.disconnect()
    assert not twin.connected
    with pytest.raises(HalError) as excinfo:
        twin.send_action(JointCommand(state.positions))
    assert excinfo.value.code == "hal.disconnected"


def test_estop_latches_until_reset(twin: MujocoTwinHal) -> None:
    twin.connect()
    try:
        start = twin.read_state().positions
        target = start.copy()
        target[0] += 0.3
        twin.send_action(JointCommand(target))
        twin.estop("test")
        held = twin.read_state().positions
        for _ in range(3):  # every later command is refused, not only the first
            with pytest.raises(EstopLatched) as excinfo:
                twin.send_action(JointCommand(target))
            assert excinfo.value.code == "hal.estop"
        time.sleep(0.3)
        after = twin.read_state().positions
        assert abs(after[0] - held[0]) < 0.02, "the arm kept moving toward the refused target"
        twin.estop("second")  # already latched: the first reason stays
        assert twin.estop_reason == "test"
        twin.reset_estop()
        twin.send_action(JointCommand(target))
        time.sleep(0.4)
        assert abs(twin.read_state().positions[0] - target[0]) < 0.05
    finally:
        twin.reset_estop()
        twin.disconnect()


class DelayedBusTwin(MujocoTwinHal):
    """The twin behind a bus that delivers each joint reading `delay` seconds after it was sampled."""

    delay = 0.0

    def _read_state(self) -> RobotState:
        state = super()._read_state()
        time.sleep(self.delay)
        return state


def test_stale_joint_state_is_detected() -> None:
    hal = DelayedBusTwin(registry.ROBOTS["ur5e"], cameras=[])
    hal.connect()
    try:
        hal.read_state()  # fresh
        hal.delay = hal.max_state_age + 0.05
        with pytest.raises(StaleState) as excinfo:
            hal.read_state()
        assert excinfo.value.code == "hal.stale"
    finally:
        hal.disconnect()


def _filter(mode: str = "clamp", workspace: Workspace | None = None, twin: MujocoTwinHal | None = None) -> SafetyFilter:
    robot = registry.ROBOTS["ur5e"]
    robot = robot.model_copy(update={"safety": SafetyConfig(mode=mode, workspace=workspace)})  # type: ignore[arg-type]
    return SafetyFilter(robot, fk=None if twin is None else twin.forward_kinematics)


def test_joint_and_velocity_limits_clamp_and_are_reported() -> None:
    f = _filter()
    state = np.array([0, -1.5, 1.5, -1.5, -1.5, 0, 0.5], dtype=np.float32)
    action = state.copy()
    action[2] = 4.0  # elbow limit is 3.14159
    res = f.apply(action, state, dt=10.0)  # a long period: only the joint limit binds
    assert res.applied is not None and res.applied[2] == pytest.approx(3.14159, abs=1e-5)
    assert [(i.kind, i.name) for i in res.interventions] == [("joint_limit", "elbow_joint")]

    action = state.copy()
    action[0] = 1.0  # 1 rad in 50 ms, limit 3.14 rad/s -> 0.157 rad
    res = f.apply(action, state, dt=0.05)
    assert res.applied is not None and res.applied[0] == pytest.approx(0.157, abs=1e-5)
    assert [(i.kind, i.name, i.commanded) for i in res.interventions] == [("velocity_limit", "shoulder_pan_joint", 1.0)]

    res = f.apply(state.copy(), state, dt=0.05)
    assert res.interventions == [] and np.array_equal(res.applied, state)  # type: ignore[arg-type]


def test_refuse_mode_sends_nothing() -> None:
    f = _filter("refuse")
    state = np.zeros(7, dtype=np.float32)
    action = state.copy()
    action[1] = 0.5
    res = f.apply(action, state, dt=0.05)
    assert res.refused and res.interventions[0].applied is None


def test_workspace_bound_on_the_twin(twin: MujocoTwinHal) -> None:
    twin.connect()
    try:
        state = twin.read_state().positions
        ee = twin.forward_kinematics(state.astype(np.float64))
        box = Workspace(x=(-2, 2), y=(-2, 2), z=(-1, float(ee[2]) + 0.02))  # 2 cm of headroom above the hand
        lift = state.copy()
        lift[1] -= 0.3  # shoulder up: the hand rises
        assert twin.forward_kinematics(lift.astype(np.float64))[2] > ee[2] + 0.05
        f = _filter("clamp", box, twin)
        res = f.apply(lift, state, dt=1.0)
        assert res.applied is not None
        z = twin.forward_kinematics(res.applied.astype(np.float64))[2]
        assert ee[2] < z <= ee[2] + 0.02 + 1e-6, "moved up to the box top, not beyond"
        assert [i.kind for i in res.interventions] == ["workspace"]
        refused = _filter("refuse", box, twin).apply(lift, state, dt=1.0)
        assert refused.refused
    finally:
        twin.disconnect()


def test_workspace_without_kinematics_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match=r"safety\.workspace"):
        _filter("clamp", Workspace(x=(0, 1), y=(0, 1), z=(0, 1)))


def test_keyboard_operator_reads_a_terminal() -> None:
    master, slave = os.openpty()
    try:
        op = KeyboardOperator(slave)
        os.write(master, b" ")
        assert op.wait_start(0) is Command.START
        assert op.poll(0, 3) is None
        os.write(master, b"s")
        time.sleep(0.05)
        assert op.poll(0, 4) is Command.SUCCESS
        for key, cmd in (
            (b"f", Command.FAILURE),
            (b"d", Command.DISCARD),
            (b"r", Command.RERECORD),
            (b"x", Command.ESTOP),
        ):
            os.write(master, key)
            time.sleep(0.05)
            assert op.poll(0, 5) is cmd
        op.close()
    finally:
        os.close(master)
        os.close(slave)


def test_keyboard_operator_needs_a_terminal(tmp_path: object) -> None:
    r, w = os.pipe()
    try:
        with pytest.raises(UsageError, match="not a terminal") as excinfo:  # which usage mistake: only the wording says
            KeyboardOperator(r)
        assert excinfo.value.code == "usage"
    finally:
        os.close(r)
        os.close(w)


def test_operator_script() -> None:
    op = ScriptedOperator(parse_script("success@3, discard@2,failure"))
    assert op.wait_start(0) is Command.START
    assert op.poll(0, 2) is None and op.poll(0, 3) is Command.SUCCESS
    op.wait_start(1)
    assert op.poll(1, 2) is Command.DISCARD
    op.wait_start(1)
    assert op.poll(1, 1000) is None and op.current() is not None  # failure at the step limit
    for bad, msg in (("win@3", "unknown verdict"), ("success@0", "frame count"), ("success@x", "frame count")):
        with pytest.raises(UsageError, match=msg) as excinfo:  # which usage mistake: only the wording says
            parse_script(bad)
        assert excinfo.value.code == "usage"
