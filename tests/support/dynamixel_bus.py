"""SIMULATED Dynamixel serial bus for tests — no hardware involved.

A pseudo-terminal (tests/support/pty_device.py) whose far end speaks DYNAMIXEL Protocol 2.0, the packets lerobot's
`DynamixelMotorsBus` sends through dynamixel_sdk and pyserial: header FF FF FD 00, id, 2-byte length,
instruction, parameters, CRC-16 (polynomial 0x8005), byte stuffing (FF FF FD -> FF FF FD FD) both ways; PING
(model number + firmware), READ, WRITE, SYNC_READ, SYNC_WRITE on the X-series control table (lerobot's
`X_SERIES_CONTROL_TABLE`): model number at 0, Drive_Mode 10, Operating_Mode 11, Homing_Offset 20 (signed),
Max/Min_Position_Limit 48/52, Torque_Enable 64, Goal_Position 116, Present_Position 132 (signed, 4 bytes,
= shaft position + Homing_Offset). Enabling torque sets Goal_Position to Present_Position (as the firmware does);
with torque on, the shaft moves toward the goal at `speed` steps/s, so the driver sees an arm that follows its
commands. What it does NOT reproduce: electrical timing, baud-rate switching, bus noise, current/velocity
control, profiles, PID behaviour, Drive_Mode's direction reversal (stored, not applied), servo firmware beyond the
registers above.

The Koch pair (lerobot's koch_follower and koch_leader): motor ids 1..6, models `KOCH_FOLLOWER_MODELS` /
`KOCH_LEADER_MODELS`, position limits `KOCH_RANGES`; `write_koch_calibration` writes the file `lerobot-calibrate`
would for an arm on this bus, and a bus built with the same `drive_modes` holds that calibration in its registers.
The OMX pair (lerobot's omx_follower, ids 11..16, and omx_leader, ids 1..6): models `OMX_FOLLOWER_MODELS` /
`OMX_LEADER_MODELS`, lerobot's factory calibration (`OMX_RANGES`: 0..4095 everywhere; the leader's gripper inverted
with homing offset 100: `OMX_LEADER_DRIVE_MODES`, `OMX_LEADER_HOMING`), written by `write_omx_calibration`.

dynamixel_sdk (3.8.4) sends its instructions unstuffed (txPacket drops the lengthened packet addStuffing makes);
this bus unstuffs what arrives as a servo does, and stuffs its replies, which the SDK's rxPacket unstuffs.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

from dynamixel_sdk.port_handler import PortHandler

from tests.support.pty_device import PtyDevice

KOCH_MOTORS = ("shoulder_pan", "shoulder_lift", "elbow_flex", "wrist_flex", "wrist_roll", "gripper")  # ids 1..6
XL430_W250, XL330_M288, XL330_M077 = 1060, 1200, 1190  # lerobot's MODEL_NUMBER_TABLE
KOCH_FOLLOWER_MODELS = {1: XL430_W250, 2: XL430_W250, 3: XL330_M288, 4: XL330_M288, 5: XL330_M288, 6: XL330_M288}
KOCH_LEADER_MODELS = dict.fromkeys(range(1, 7), XL330_M077)
# what lerobot-calibrate records for a Koch arm: full turns for the pan and the wrist roll, the joints' swept
# ranges for the others; the leader's elbow is mounted reversed (drive mode 1)
KOCH_RANGES = {1: (0, 4095), 2: (1024, 3072), 3: (1024, 3072), 4: (1024, 3072), 5: (0, 4095), 6: (1500, 2600)}
LEADER_DRIVE_MODES = {3: 1}
OMX_FOLLOWER_MODELS = {11: XL430_W250, 12: XL430_W250, 13: XL430_W250, 14: XL330_M288, 15: XL330_M288, 16: XL330_M288}
OMX_LEADER_MODELS = {**dict.fromkeys(range(1, 6), XL330_M288), 6: XL330_M077}
OMX_RANGES = dict.fromkeys([*range(1, 7), *range(11, 17)], (0, 4095))
OMX_LEADER_DRIVE_MODES, OMX_LEADER_HOMING = {6: 1}, {6: 100}

PING, READ, WRITE, SYNC_READ, SYNC_WRITE, STATUS = 0x01, 0x02, 0x03, 0x82, 0x83, 0x55
BROADCAST = 0xFE
HEADER = b"\xff\xff\xfd\x00"
ADDR = {  # name: (address, size)
    "model": (0, 2),
    "firmware": (6, 1),
    "id": (7, 1),
    "drive_mode": (10, 1),
    "operating_mode": (11, 1),
    "homing": (20, 4),
    "max": (48, 4),
    "min": (52, 4),
    "torque": (64, 1),
    "goal": (116, 4),
    "present": (132, 4),
}


class Servo:
    def __init__(self, sid: int, model: int, position: int, limits: tuple[int, int], speed: float) -> None:
        self.id = sid
        self.regs = bytearray(256)
        self.set("model", model)
        self.set("firmware", 52)
        self.set("id", sid)
        self.set("operating_mode", 3)
        self.set("min", limits[0])
        self.set("max", limits[1])
        self.position = float(position)  # the shaft, before Homing_Offset
        self.set("present", position)
        self.set("goal", position)
        self.speed = speed
        self.last = time.monotonic()
        self.writes = 0

    def get(self, name: str) -> int:
        addr, size = ADDR[name]
        return int.from_bytes(self.regs[addr : addr + size], "little", signed=size == 4)

    def set(self, name: str, value: int) -> None:
        addr, size = ADDR[name]
        self.regs[addr : addr + size] = value.to_bytes(size, "little", signed=size == 4 and value < 0)

    def update(self) -> None:
        now = time.monotonic()
        dt, self.last = now - self.last, now
        homing = self.get("homing")
        if self.get("torque"):
            step = self.speed * dt
            self.position += max(-step, min(step, self.get("goal") - homing - self.position))
        self.set("present", round(self.position) + homing)

    def write(self, addr: int, data: bytes) -> None:
        torque_was = self.get("torque")
        self.regs[addr : addr + len(data)] = data
        present = ADDR["present"][0]
        if addr <= present < addr + len(data):  # a test placing the shaft
            self.position = float(self.get("present") - self.get("homing"))
        if self.get("torque") and not torque_was:  # the firmware holds where it is
            self.regs[ADDR["goal"][0] : ADDR["goal"][0] + 4] = self.regs[present : present + 4]
        self.writes += 1


def crc16(data: bytes) -> int:
    """Protocol 2.0's CRC-16 (polynomial 0x8005, initial 0, unreflected)."""
    crc = 0
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) if crc & 0x8000 else crc << 1
            crc &= 0xFFFF
    return crc


def stuff(body: bytes) -> bytes:
    """FF FF FD inside a packet's body goes out as FF FF FD FD."""
    out = bytearray()
    for b in body:
        out.append(b)
        if out[-3:] == b"\xff\xff\xfd":
            out.append(0xFD)
    return bytes(out)


def unstuff(body: bytes) -> bytes:
    return body.replace(b"\xff\xff\xfd\xfd", b"\xff\xff\xfd")


def status_packet(sid: int, params: bytes, error: int = 0) -> bytes:
    body = stuff(bytes([STATUS, error, *params]))
    head = HEADER + bytes([sid]) + (len(body) + 2).to_bytes(2, "little") + body
    return head + crc16(head).to_bytes(2, "little")


class SimulatedDynamixelBus(PtyDevice):
    """Serves X-series servos `models` (id -> model number) on a pty; `port` is the path the driver opens."""

    def __init__(self, models: dict[int, int], *, position: int = 2048, drive_modes: dict[int, int] | None = None,
                 speed: float = 3000.0, ranges: dict[int, tuple[int, int]] = KOCH_RANGES,
                 homing: dict[int, int] | None = None) -> None:  # fmt: skip
        self.servos = {i: Servo(i, m, position, ranges[i], speed) for i, m in models.items()}
        for i, mode in (drive_modes or {}).items():
            self.servos[i].set("drive_mode", mode)
        for i, offset in (homing or {}).items():
            self.servos[i].set("homing", offset)
            self.servos[i].update()
        self.packets = 0
        self.position_reads: list[dict[int, int]] = []  # every SYNC_READ of Present_Position: id -> value sent
        super().__init__("dynamixel-sim", PortHandler)

    def parse(self) -> None:
        buf = self.buffer
        while True:
            start = buf.find(HEADER)
            if start < 0:
                del buf[: max(0, len(buf) - 3)]  # keep a header's beginning
                return
            del buf[:start]
            if len(buf) < 7:
                return
            total = 7 + int.from_bytes(buf[5:7], "little")
            if len(buf) < total:
                return
            pkt = bytes(buf[:total])
            del buf[:total]
            if crc16(pkt[:-2]) != int.from_bytes(pkt[-2:], "little"):
                continue  # corrupt: a real servo stays silent
            self.packets += 1
            body = unstuff(pkt[7:-2])
            self._handle(pkt[4], body[0], body[1:])

    def _handle(self, sid: int, inst: int, params: bytes) -> None:
        for s in self.servos.values():
            s.update()
        if inst in (SYNC_READ, SYNC_WRITE):
            addr, n = int.from_bytes(params[0:2], "little"), int.from_bytes(params[2:4], "little")
            if inst == SYNC_WRITE:
                for k in range(4, len(params), n + 1):
                    if (servo := self.servos.get(params[k])) is not None:
                        servo.write(addr, params[k + 1 : k + 1 + n])
                return
            ids = [i for i in params[4:] if i in self.servos]
            if addr == ADDR["present"][0]:
                self.position_reads.append({i: self.servos[i].get("present") for i in ids})
            self.reply(b"".join(status_packet(i, bytes(self.servos[i].regs[addr : addr + n])) for i in ids))
            return
        if inst == PING and sid == BROADCAST:
            self.reply(
                b"".join(status_packet(i, bytes(s.regs[0:2]) + bytes(s.regs[6:7])) for i, s in self.servos.items())
            )
            return
        if (servo := self.servos.get(sid)) is None:
            return  # nobody answers
        if inst == PING:
            self.reply(status_packet(sid, bytes(servo.regs[0:2]) + bytes(servo.regs[6:7])))
        elif inst == READ:
            addr, n = int.from_bytes(params[0:2], "little"), int.from_bytes(params[2:4], "little")
            self.reply(status_packet(sid, bytes(servo.regs[addr : addr + n])))
        elif inst == WRITE:
            servo.write(int.from_bytes(params[0:2], "little"), params[2:])
            self.reply(status_packet(sid, b""))


def write_koch_calibration(path: Path, drive_modes: dict[int, int] | None = None) -> Path:
    """A calibration file like `lerobot-calibrate` writes for a Koch arm on this bus (KOCH_RANGES, homing 0)."""
    return write_calibration(path, KOCH_RANGES, drive_modes)


def write_omx_calibration(path: Path, ids: range, drive_modes: dict[int, int] | None = None,
                          homing: dict[int, int] | None = None) -> Path:  # fmt: skip
    """The factory calibration lerobot's OMX classes save for an arm with servo `ids` (OMX_RANGES)."""
    return write_calibration(path, {i: OMX_RANGES[i] for i in ids}, drive_modes, homing)


def write_calibration(path: Path, ranges: dict[int, tuple[int, int]], drive_modes: dict[int, int] | None = None,
                      homing: dict[int, int] | None = None) -> Path:  # fmt: skip
    """lerobot's calibration file of a six-servo arm (KOCH_MOTORS' names, in id order) on this bus."""
    path.parent.mkdir(parents=True, exist_ok=True)
    modes, offsets = drive_modes or {}, homing or {}
    cal = {
        m: {
            "id": i,
            "drive_mode": modes.get(i, 0),
            "homing_offset": offsets.get(i, 0),
            "range_min": lo,
            "range_max": hi,
        }
        for m, (i, (lo, hi)) in zip(KOCH_MOTORS, ranges.items(), strict=True)
    }
    path.write_text(json.dumps(cal))
    return path


def normalized(raw: int, sid: int, ranges: dict[int, tuple[int, int]]) -> float:
    """lerobot's normalisation of servo `sid`'s reading on a six-servo arm: -100..100 of its calibrated range, the
    gripper (id 6 or 16) 0..100 (lerobot's Dynamixel bus does not apply the drive mode)."""
    lo, hi = ranges[sid]
    part = (min(hi, max(lo, raw)) - lo) / (hi - lo)
    return part * 100 if sid % 10 == 6 else part * 200 - 100
