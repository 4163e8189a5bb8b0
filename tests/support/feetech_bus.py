"""SIMULATED Feetech serial bus for tests — no hardware involved.

A pseudo-terminal whose far end speaks the Feetech SCS/STS protocol 0 (the packets lerobot's
`FeetechMotorsBus` sends through the scservo SDK and pyserial): PING, READ, WRITE, SYNC_READ, SYNC_WRITE on a
256-byte register file per servo (STS3215 layout: model number 777 at address 3, limits, homing offset,
torque enable, goal/present position). Present_Position moves toward Goal_Position at `speed` steps/s
while torque is on, so the driver sees an arm that actually follows its commands. lerobot's driver and the
scservo SDK run unchanged against it; what it does NOT reproduce: electrical timing, baud-rate switching,
bus noise, current/load/temperature, servo firmware behaviour beyond the registers above.

The pty, its serving thread and the SDK's patient timeout check: tests/support/pty_device.py.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from scservo_sdk.port_handler import PortHandler

from tests.support.pty_device import PtyDevice

SO_MOTORS = ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll", "gripper")  # ids 1..6
PING, READ, WRITE, SYNC_READ, SYNC_WRITE = 0x01, 0x02, 0x03, 0x82, 0x83
BROADCAST = 0xFE
MODEL_STS3215 = 777
ADDR = {
    "fw_major": 0,
    "fw_minor": 1,
    "model": 3,
    "min": 9,
    "max": 11,
    "homing": 31,
    "torque": 40,
    "goal": 42,
    "lock": 55,
    "present": 56,
}


class Servo:
    def __init__(self, sid: int, position: int, range_min: int, range_max: int, speed: float) -> None:
        self.id = sid
        self.regs = bytearray(256)
        self.regs[ADDR["fw_major"]] = 3
        self.regs[ADDR["fw_minor"]] = 10
        self.set16("model", MODEL_STS3215)
        self.set16("min", range_min)
        self.set16("max", range_max)
        self.set16("homing", 0)
        self.set16("present", position)
        self.set16("goal", position)
        self.position = float(position)
        self.speed = speed
        self.last = time.monotonic()
        self.writes = 0

    def get16(self, name: str) -> int:
        a = ADDR[name]
        return self.regs[a] | (self.regs[a + 1] << 8)

    def set16(self, name: str, value: int) -> None:
        a = ADDR[name]
        self.regs[a] = value & 0xFF
        self.regs[a + 1] = (value >> 8) & 0xFF

    def update(self) -> None:
        now = time.monotonic()
        dt, self.last = now - self.last, now
        if self.regs[ADDR["torque"]]:
            goal = self.get16("goal")
            step = self.speed * dt
            self.position += max(-step, min(step, goal - self.position))
        self.set16("present", round(self.position))


def _packet(sid: int, error: int, params: bytes) -> bytes:
    body = bytes([sid, len(params) + 2, error, *params])
    return b"\xff\xff" + body + bytes([~sum(body) & 0xFF])


class SimulatedFeetechBus(PtyDevice):
    """Serves servos `ids` on a pty; `port` is the path the driver opens."""

    def __init__(self, ids: list[int], *, position: int = 2048, range_min: int = 1024, range_max: int = 3072,
                 speed: float = 3000.0) -> None:  # fmt: skip
        self.servos = {i: Servo(i, position, range_min, range_max, speed) for i in ids}
        self.packets = 0
        self.position_reads: list[dict[int, int]] = []  # every SYNC_READ of Present_Position: id -> value sent
        super().__init__("feetech-sim", PortHandler)

    def parse(self) -> None:
        buf = self.buffer
        while True:
            start = buf.find(b"\xff\xff")
            if start < 0:
                buf.clear()
                return
            del buf[:start]
            if len(buf) < 4:
                return
            length = buf[3]
            total = 4 + length
            if len(buf) < total:
                return
            pkt = bytes(buf[:total])
            del buf[:total]
            if (~sum(pkt[2:-1]) & 0xFF) != pkt[-1]:
                continue  # corrupt: a real servo stays silent
            self.packets += 1
            self._handle(pkt[2], pkt[4], pkt[5:-1])

    def _handle(self, sid: int, inst: int, params: bytes) -> None:
        for s in self.servos.values():
            s.update()
        if inst == SYNC_WRITE:
            addr, n = params[0], params[1]
            for k in range(2, len(params), n + 1):
                servo = self.servos.get(params[k])
                if servo is not None:
                    servo.regs[addr : addr + n] = params[k + 1 : k + 1 + n]
                    servo.writes += 1
            return
        if inst == SYNC_READ:
            addr, n = params[0], params[1]
            if addr == ADDR["present"]:
                self.position_reads.append({i: self.servos[i].get16("present") for i in params[2:] if i in self.servos})
            self.reply(
                b"".join(
                    _packet(i, 0, bytes(self.servos[i].regs[addr : addr + n])) for i in params[2:] if i in self.servos
                )
            )
            return
        servo = self.servos.get(sid)
        if servo is None:
            return  # nobody answers
        if inst == PING:
            self.reply(_packet(sid, 0, b""))
        elif inst == READ:
            addr, n = params[0], params[1]
            self.reply(_packet(sid, 0, bytes(servo.regs[addr : addr + n])))
        elif inst == WRITE:
            addr = params[0]
            servo.regs[addr : addr + len(params) - 1] = params[1:]
            if addr <= ADDR["present"] < addr + len(params) - 1:
                servo.position = float(servo.get16("present"))
            servo.writes += 1
            self.reply(_packet(sid, 0, b""))


def write_so_calibration(path: Path, range_min: int = 1024, range_max: int = 3072) -> Path:
    """A calibration file like `lerobot-calibrate` writes for an SO arm (follower or leader) on this bus."""
    path.parent.mkdir(parents=True, exist_ok=True)
    cal = {
        m: {"id": i + 1, "drive_mode": 0, "homing_offset": 0, "range_min": range_min, "range_max": range_max}
        for i, m in enumerate(SO_MOTORS)
    }
    path.write_text(json.dumps(cal))
    return path


def calibrated_so_project(project: Path, robot: str) -> Path:
    """`project`'s SO manifest for `robot` pointing at a calibration file like `lerobot-calibrate` writes."""
    import yaml

    write_so_calibration(project / "robots" / robot / "calibration" / f"{robot}.json")
    path = project / "robots" / robot / "robot.yaml"
    manifest = yaml.safe_load(path.read_text())
    manifest["hardware"]["calibration_dir"] = "calibration"
    path.write_text(yaml.safe_dump(manifest, sort_keys=False))
    return project


def so_normalized(raw: int, sid: int, range_min: int = 1024, range_max: int = 3072) -> float:
    """lerobot's normalisation of an SO arm's reading (use_degrees): degrees about the middle of the range (STS3215:
    4096 steps), the gripper (id 6) 0..100 of its range."""
    if sid == 6:
        return (raw - range_min) / (range_max - range_min) * 100
    return (raw - (range_min + range_max) / 2) * 360 / 4095
