"""Teleoperation from a terminal keyboard: a person drives a scene's `delta_eef_gripper` action.

`KeyboardTeleop` is a policy (reset / step / close, the `PolicyAdapter` protocol) whose actions come from keys,
so a teleoperated episode goes through the same loop, safety filter, contract checks and bridge as an rSkill.
The keys arrive from the operator's terminal reader (`KeyboardOperator(listener=teleop.feed)`: one reader of
the one tty, so the operator keys s/f/d/r/q/x keep working); no display is needed (lerobot's
`KeyboardTeleop` uses pynput, which needs an X server).

A terminal reports key presses, never releases, so every press is one **step**: `i`/`k` (or up/down arrows)
move the end effector ±`step` m along world x, `j`/`l` (left/right arrows) ±`step` along y, `u`/`m` ±`step`
along z, `[`/`]` turn ±`yaw_step` rad about z; `g` toggles the gripper (0 open, 1 closed); `h` drops the moves
not yet made. Presses add up and are paid out at most `max_step` m (and `yaw_step` rad) per axis and tick, so a
held key (the terminal's auto-repeat) moves the arm steadily and a burst of presses is spread over the next
ticks; at most `max_queue` steps wait per axis. Keys are digital: there is no deadzone (an analog device would
need one). Every `status_every` ticks a status line (end-effector position, gripper, moves pending) is written
to the terminal, so a person without a camera view can see where the gripper is.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
import numpy.typing as npt

from openral_data.errors import ConfigError
from openral_data.producers.hal.teleop.declare import DeviceRequest, TeleopDevice
from openral_data.producers.hal.teleop.keys import ARROWS, AXES, GRIPPER_KEY, HALT_KEY, HELP, TAKEOVER_KEY
from openral_data.producers.hal.teleop.status import eef_line, status_lines
from openral_data.schemas.rskill import RSkillManifest
from openral_data.types import Observation

REPRESENTATION = "delta_eef_gripper"
KEYS = frozenset([*AXES, GRIPPER_KEY, HALT_KEY])


@dataclass(frozen=True)
class KeyboardGains:
    """Step sizes of one key press and how fast they are paid out (documented in docs/hal.md)."""

    step: float = 0.01  # m of end-effector travel per press
    yaw_step: float = 0.05  # rad about world z per press
    max_step: float = 0.02  # m per axis and tick at most (presses beyond it wait for the next ticks)
    max_queue: int = 10  # presses that can wait per axis (more are dropped)
    status_every: int = 4  # ticks between status lines (0: none)

    def scaled(self, gain: float) -> KeyboardGains:
        """`record --teleop-gain G`: every press moves G times as far (and is paid out G times as fast)."""
        return replace(self, step=self.step * gain, yaw_step=self.yaw_step * gain, max_step=self.max_step * gain)


class KeyboardTeleop:
    """Keys (fed one character at a time) -> `delta_eef_gripper` actions [dx, dy, dz, 0, 0, dyaw, gripper]."""

    def __init__(
        self,
        rskill: RSkillManifest,
        source: str,
        gains: KeyboardGains | None = None,
        show: Callable[[str], None] | None = None,
    ) -> None:
        self.low, self.high = eef_limits(rskill, source, "keyboard")
        self.gains = gains or KeyboardGains()
        self.show = show
        self._escape = ""
        self.pending = np.zeros(4)  # presses waiting per axis: x, y, z, yaw
        self.gripper = 0.0
        self.ticks = 0

    def feed(self, ch: str) -> None:
        """One character from the terminal (arrow keys arrive as ESC [ A..D)."""
        if self._escape or ch == "\x1b":
            self._escape += ch
            if len(self._escape) < 3:
                return
            ch, self._escape = ARROWS.get(self._escape[2], ""), ""
        if ch in AXES:
            axis, sign = AXES[ch]
            cap = self.gains.max_queue
            self.pending[axis] = min(cap, max(-cap, self.pending[axis] + sign))
        elif ch == GRIPPER_KEY:
            self.gripper = 1.0 - self.gripper
        elif ch == HALT_KEY:
            self.pending[:] = 0

    def reset(self, seed: int) -> None:
        self.pending[:] = 0
        self.gripper = 0.0
        self.ticks = 0
        self._escape = ""

    def take_over(self, action: npt.NDArray[np.float32]) -> None:
        """Start from `action`, the one in effect (an intervention's takeover, policies/intervention.py): no
        moves pending (the arm stays where it is) and the gripper as the action had it (closed from 0.5 on)."""
        self.pending[:] = 0
        self._escape = ""
        self.gripper = held_gripper(action)

    def step(self, observation: Observation, instruction: str) -> npt.NDArray[np.float32]:
        g = self.gains
        per_tick = np.array([g.max_step / g.step] * 3 + [1.0])
        paid = np.clip(self.pending, -per_tick, per_tick)
        self.pending -= paid
        move = paid * np.array([g.step] * 3 + [g.yaw_step])
        action = np.array([*move[:3], 0.0, 0.0, move[3], self.gripper])
        if self.show is not None and g.status_every and self.ticks % g.status_every == 0:
            self.show(status(observation, self.gripper, self.pending))
        self.ticks += 1
        return np.clip(action, self.low, self.high).astype(np.float32)

    def close(self) -> None:
        pass


def held_gripper(action: npt.NDArray[np.float32]) -> float:
    """The gripper a teleoperator keeps at a takeover from `action` (`delta_eef_gripper`): closed (1) from 0.5 on,
    else open (0)."""
    return 1.0 if float(action[6]) >= 0.5 else 0.0


def eef_limits(
    rskill: RSkillManifest, source: str, device: str
) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """The action bounds of a `delta_eef_gripper` (dim 7) contract, the only one a teleoperation device drives."""
    contract = rskill.action_contract
    if contract.representation != REPRESENTATION or contract.dim != 7:
        raise ConfigError(
            f"{source}: action_contract.representation: {device} teleoperation drives {REPRESENTATION} (dim 7), "
            f"got {contract.representation} (dim {contract.dim})"
        )
    low = np.asarray(contract.low if contract.low is not None else [-np.inf] * 7, dtype=np.float64)
    high = np.asarray(contract.high if contract.high is not None else [np.inf] * 7, dtype=np.float64)
    return low, high


def status(observation: Observation, gripper: float, pending: npt.NDArray[np.float64]) -> str:
    """`eef 0.412 -0.031 0.911 gripper open pending 0 0 0 0` (`eef_line` and the key presses not yet paid out),
    and the scene's line under it (status.py)."""
    moves = " ".join(str(int(p)) for p in pending)
    return status_lines(observation, f"{eef_line(observation, gripper)} pending {moves}")


def tty_status(fd: int, talk: bool = True) -> Callable[[str], None] | None:
    """Show a status line on the terminal `fd`, overwriting the previous one; None (no status lines) when the run
    says nothing (`talk` False: -q, --json) or `fd` is not a terminal (a file or a pipe: a log, not a person)."""
    if not talk or not os.isatty(fd):
        return None

    def show(line: str) -> None:
        os.write(fd, f"\r\x1b[K{line}\r\n".encode())

    return show


def open_keyboard(request: DeviceRequest) -> KeyboardTeleop:
    return KeyboardTeleop(request.rskill, request.source, KeyboardGains().scaled(request.gain), show=request.show)


DEVICE = TeleopDevice("keyboard", open_keyboard, TAKEOVER_KEY, terminal=True, keys=HELP)
