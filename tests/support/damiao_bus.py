"""A simulated CAN bus of Damiao motors (an OpenArm's DM8009/DM4340/DM4310) that lerobot 0.6.1's unmodified
`DamiaoMotorsBus` talks to through python-can's `virtual` interface (the same in-process channel: the test's
simulator thread on one end, lerobot's driver on the other; no socketcan device needed).

The frames are the motors' (lerobot/motors/damiao, after DM_Control_Python): to the motor's CAN id, seven 0xFF
then 0xFC enable, 0xFD disable, 0xFE set the present position as zero; an MIT command (8 bytes: position 16 bit
over ±PMAX rad, velocity 12 bit over ±VMAX, kp 12 bit over 0..500, kd 12 bit over 0..5, feed-forward torque 12
bit over ±TMAX); to 0x7FF `[id lo, id hi, 0xCC, 0...]` refresh. Every one is answered from the motor's master
id with its feedback frame: `[id | err << 4, q hi, q lo, dq hi, dq lo << 4 | tau hi, tau lo, T_mos, T_rotor]`.

A motor with torque enabled and kp > 0 follows its last MIT position target as a first-order servo (time
constant `tau`, advanced on every frame), or, with `physics=TwinPhysics(...)`, as the robot's MuJoCo twin moves
under those targets (its servos, gravity, inertia); with torque off its shaft is where `shaft` says (a hand
moving a leader arm). Every frame in is counted by kind, every feedback frame out logged (decoded as lerobot
decodes it).
"""

from __future__ import annotations

import math
import threading
import time
import uuid
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Self

import can
import numpy as np

from tests.support.background import Background

# lerobot's OpenArm motor map (its follower config's motor_config): name -> (send id, master id, model)
OPENARM_MOTORS: dict[str, tuple[int, int, str]] = {
    "joint_1": (0x01, 0x11, "dm8009"),
    "joint_2": (0x02, 0x12, "dm8009"),
    "joint_3": (0x03, 0x13, "dm4340"),
    "joint_4": (0x04, 0x14, "dm4340"),
    "joint_5": (0x05, 0x15, "dm4310"),
    "joint_6": (0x06, 0x16, "dm4310"),
    "joint_7": (0x07, 0x17, "dm4310"),
    "gripper": (0x08, 0x18, "dm4310"),
}
# (PMAX rad, VMAX rad/s, TMAX Nm) per model (lerobot/motors/damiao/tables.py MOTOR_LIMIT_PARAMS)
LIMITS = {"dm8009": (12.5, 45.0, 54.0), "dm4340": (12.5, 8.0, 28.0), "dm4310": (12.5, 30.0, 10.0)}
PARAM_ID, REFRESH, ENABLE, DISABLE, SET_ZERO = 0x7FF, 0xCC, 0xFC, 0xFD, 0xFE


def to_uint(x: float, lo: float, hi: float, bits: int) -> int:
    return int((min(hi, max(lo, x)) - lo) / (hi - lo) * ((1 << bits) - 1))


def to_float(u: int, lo: float, hi: float, bits: int) -> float:
    return u / ((1 << bits) - 1) * (hi - lo) + lo


@dataclass
class Motor:
    """One Damiao motor: its shaft (rad, from its mechanical zero), zero offset, torque state and MIT target."""

    send_id: int
    recv_id: int
    model: str
    shaft: float = 0.0
    velocity: float = 0.0
    zero: float = 0.0
    enabled: bool = False
    kp: float = 0.0
    kd: float = 0.0
    target: float = 0.0  # rad, in the motor's (zeroed) frame
    targets: list[float] = field(default_factory=list)  # every MIT position target received (degrees)

    def advance(self, dt: float, tau: float) -> None:
        if not (self.enabled and self.kp > 0) or dt <= 0:
            return
        goal = self.target + self.zero
        step = (goal - self.shaft) * (1.0 - math.exp(-dt / tau))
        self.shaft += step
        self.velocity = step / dt

    def feedback(self) -> tuple[list[int], float]:
        """The feedback frame's data and the position (degrees) lerobot decodes from it."""
        pmax, vmax, tmax = LIMITS[self.model]
        q = to_uint(self.shaft - self.zero, -pmax, pmax, 16)
        dq = to_uint(self.velocity, -vmax, vmax, 12)
        tq = to_uint(self.kp * (self.target + self.zero - self.shaft) if self.enabled else 0.0, -tmax, tmax, 12)
        data = [self.send_id & 0x0F, q >> 8, q & 0xFF, dq >> 4, ((dq & 0xF) << 4) | (tq >> 8), tq & 0xFF, 30, 31]
        return data, math.degrees(to_float(q, -pmax, pmax, 16))

    def mit(self, data: bytes) -> None:
        pmax, _vmax, _tmax = LIMITS[self.model]
        self.target = to_float((data[0] << 8) | data[1], -pmax, pmax, 16)
        self.kp = to_float((data[3] & 0xF) << 8 | data[4], 0.0, 500.0, 12)
        self.kd = to_float(data[5] << 4 | data[6] >> 4, 0.0, 5.0, 12)
        self.targets.append(math.degrees(self.target))


class TwinPhysics:
    """The motors of `robot` (a manifest whose joints are the motors' names, in degrees from the motors' zero)
    moved by its MuJoCo twin: each enabled motor's MIT target is its joint's servo target, a disabled one holds
    where it is; the shafts are the twin's joint positions after physics caught up with the wall clock (at most
    0.5 s at once). The twin starts at the motors' zero: hanging straight down, gripper closed."""

    def __init__(self, robot: str = "openarm_follower") -> None:
        import mujoco

        from openral_data.producers.sim.mujoco.twin import Twin
        from openral_data.runtime import registry

        self.mujoco = mujoco
        self.twin = Twin(registry.ROBOTS[robot], [])
        self.data = mujoco.MjData(self.twin.model)
        self.twin.place(self.data, np.zeros(self.twin.state_dim))
        self.timestep = float(self.twin.model.opt.timestep)
        self.owed = 0.0  # simulated time still to step

    def advance(self, dt: float, motors: dict[str, Motor]) -> None:
        state = self.twin.state(self.data)
        target = [
            math.degrees(m.target) if m.enabled and m.kp > 0 else float(state[i]) for i, m in enumerate(motors.values())
        ]
        self.twin.command(self.data, target)
        self.owed = min(self.owed + dt, 0.5)
        n = int(self.owed / self.timestep)
        if n:
            self.mujoco.mj_step(self.twin.model, self.data, nstep=n)
            self.owed -= n * self.timestep
        after = self.twin.state(self.data)
        for i, m in enumerate(motors.values()):
            m.velocity = math.radians(float(after[i] - state[i])) / dt if dt > 0 else 0.0
            m.shaft = m.zero + math.radians(float(after[i]))


class SimulatedDamiaoBus(Background):
    """An arm's Damiao motors on a fresh python-can virtual channel (`channel`, what the manifest's `port` names
    with `can_interface: virtual`), answered by a thread while the context is open."""

    def __init__(
        self,
        motors: dict[str, tuple[int, int, str]] | None = None,
        tau: float = 0.02,
        physics: TwinPhysics | None = None,
    ) -> None:
        super().__init__()
        spec = motors or OPENARM_MOTORS
        self.physics = physics
        self.channel = f"openral-sim-{uuid.uuid4().hex[:8]}"
        self.motors = {name: Motor(s, r, m) for name, (s, r, m) in spec.items()}
        self._by_id = {m.send_id: m for m in self.motors.values()}
        self.tau = tau
        self.seen: Counter[str] = Counter()  # frames in, by kind: enable, disable, zero, refresh, mit, unknown
        self.reported: dict[str, list[float]] = {name: [] for name in self.motors}  # every feedback, degrees
        self.lock = threading.Lock()  # held while a frame is handled (a hand moving shafts takes it too)
        self._bus: Any = None
        self._last = time.monotonic()

    def __enter__(self) -> Self:
        self._bus = can.Bus(interface="virtual", channel=self.channel)
        return super().__enter__()

    def __exit__(self, *exc: object) -> None:
        super().__exit__(*exc)
        self._bus.shutdown()

    def run(self) -> None:
        while not self.stopping():
            msg = self._bus.recv(timeout=0.02)
            if msg is not None:
                with self.lock:
                    self._handle(msg)

    def _handle(self, msg: can.Message) -> None:
        now = time.monotonic()
        if self.physics is not None:
            self.physics.advance(now - self._last, self.motors)
        else:
            for m in self.motors.values():
                m.advance(now - self._last, self.tau)
        self._last = now
        data = bytes(msg.data)
        kind, motor = self._decode(msg.arbitration_id, data)
        self.seen[kind] += 1
        if motor is None:
            return
        if kind == "enable":
            motor.enabled, motor.target = True, motor.shaft - motor.zero
        elif kind == "disable":
            motor.enabled, motor.velocity = False, 0.0
        elif kind == "zero":
            motor.zero, motor.target = motor.shaft, 0.0
        elif kind == "mit":
            motor.mit(data)
        reply, degrees = motor.feedback()
        self.reported[self._name(motor)].append(degrees)
        self._bus.send(can.Message(arbitration_id=motor.recv_id, data=reply, is_extended_id=False, is_fd=msg.is_fd))

    def _decode(self, can_id: int, data: bytes) -> tuple[str, Motor | None]:
        if can_id == PARAM_ID and len(data) >= 3 and data[2] == REFRESH:
            return "refresh", self._by_id.get(data[0] | data[1] << 8)
        motor = self._by_id.get(can_id)
        if motor is None or len(data) != 8:
            return "unknown", None
        if data[:7] == b"\xff" * 7 and data[7] in (ENABLE, DISABLE, SET_ZERO):
            return {ENABLE: "enable", DISABLE: "disable", SET_ZERO: "zero"}[data[7]], motor
        return "mit", motor

    def _name(self, motor: Motor) -> str:
        return next(n for n, m in self.motors.items() if m is motor)

    def degrees(self, name: str) -> float:
        """Where `name`'s shaft is now, in the degrees lerobot reports (from the motor's zero)."""
        with self.lock:
            m = self.motors[name]
            return math.degrees(m.shaft - m.zero)


# where the hand holds the leader's joints (degrees, inside lerobot's left-arm limits) after it was zeroed
POSTURE = {"joint_2": -30.0, "joint_4": 45.0, "gripper": -30.0}


class LeaderHand(Background):
    """A person moving a leader arm whose torque is off: it is held at its zero (hanging, gripper closed) until
    lerobot has zeroed every motor (OpenArmLeader.connect sets the zero where the arm stands), then each joint
    swings ±`amplitude` degrees around `POSTURE`, both faded in over `ramp` seconds so no joint outruns the
    manifest's velocity limits (a thread setting the motors' shafts)."""

    def __init__(
        self, bus: SimulatedDamiaoBus, amplitude: float = 15.0, period: float = 2.0, ramp: float = 1.0
    ) -> None:
        super().__init__()
        self.bus = bus
        self.amplitude = amplitude
        self.period = period
        self.ramp = ramp

    def run(self) -> None:
        while not self.stopping() and self.bus.seen["zero"] < len(self.bus.motors):
            time.sleep(0.005)
        t0 = time.monotonic()
        while not self.stopping():
            t = time.monotonic() - t0
            phase, fade = 2 * math.pi * t / self.period, min(1.0, t / self.ramp)
            with self.bus.lock:
                for i, (name, m) in enumerate(self.bus.motors.items()):
                    if not m.enabled:
                        deg = fade * (POSTURE.get(name, 0.0) + self.amplitude * math.sin(phase + i))
                        m.shaft = m.zero + math.radians(deg)
            time.sleep(0.005)


def write_openarm_calibration(path: Path, motors: dict[str, tuple[int, int, str]] | None = None) -> Path:
    """The calibration file lerobot's OpenArm `calibrate()` writes (Damiao motors keep none: -90..90 each)."""
    import json

    spec = motors or OPENARM_MOTORS
    cal = {
        name: {"id": send, "drive_mode": 0, "homing_offset": 0, "range_min": -90, "range_max": 90}
        for name, (send, _recv, _model) in spec.items()
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(cal, indent=4))
    return path
