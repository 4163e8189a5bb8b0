"""Who drives a recording: one typed choice, made here once from `--rskill`, `--policy` and `--teleop`.

Every combination of the three maps to exactly one `DriverKind` or is refused with one line; `record` (a scene,
`--teleop`, `--hal`) and `HalRecordOptions` (the Python API) both ask `choose_driver`. Each kind is opened by its
own module in this package (`open_driver`)."""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path

from openral_data.errors import UsageError
from openral_data.producers.hal.teleop.declare import TeleopDevice
from openral_data.producers.hal.teleop.devices import LEADER, find_device

POLICY_AND_LEADER = "--policy: not with --teleop leader (takeover devices: keyboard, gamepad, spacemouse, expert)"
POLICY_AND_TELEOP = "--policy: not with --teleop unless the device takes over (takeover=True: an intervention session)"


class DriverKind(StrEnum):
    RSKILL = "rskill"  # an rSkill's policy (a learned one, or a script: record/drivers/names.py names which)
    CHECKPOINT = "checkpoint"  # a lerobot checkpoint (`--policy`)
    PERSON = "person"  # a person through a teleop device (keyboard, gamepad, SpaceMouse)
    LEADER = "leader"  # a person through the robot's leader arm (its manifest's hardware.teleop)
    TAKEOVER = "takeover"  # an rSkill's policy, and a person takes over and hands back (interventions)


OWN_CONTRACT = (DriverKind.CHECKPOINT, DriverKind.LEADER)  # need no rSkill: the robot's joints are the contract


@dataclass(frozen=True)
class DriverChoice:
    kind: DriverKind
    device: TeleopDevice | None = None  # PERSON, TAKEOVER: the person's device
    node: Path | None = None  # ... its node (`--teleop NAME=NODE`); None: the first one found

    @property
    def person(self) -> bool:
        """A person is at the controls (the recording is a `--hal` one, at a fixed rate)."""
        return self.kind in (DriverKind.PERSON, DriverKind.LEADER, DriverKind.TAKEOVER)

    @property
    def terminal(self) -> bool:
        """The person drives from the operator's terminal (the keyboard)."""
        return self.device is not None and self.device.terminal


def choose_driver(
    rskill: str | None, policy: str | None, teleop: str | None, *, hal: bool, takeover: bool | None = None
) -> DriverChoice:
    """The driver of a recording. `hal`: a robot is given (`--hal`; a leader arm needs one). `takeover` None: an
    rSkill or a checkpoint (`policy`) with a device that can take over is an intervention session (the CLI:
    `record --policy CKPT --teleop expert` is the DAgger round, pipeline/dagger_step.py); True/False: as said
    (the API)."""
    if policy is not None and teleop is not None:
        if teleop == LEADER:
            raise UsageError(POLICY_AND_LEADER)
        if takeover is False:
            raise UsageError(POLICY_AND_TELEOP)
    if teleop == LEADER and not hal:
        raise UsageError("--teleop leader: needs --hal ROBOT_ID (the robot whose manifest names the leader)")
    device, node = find_device(teleop) if teleop is not None and teleop != LEADER else (None, None)
    if policy is not None and rskill is not None:
        raise UsageError("--policy, --rskill: give one (a lerobot checkpoint, or an rSkill manifest)")
    takes_over = (rskill is not None or policy is not None) and device is not None if takeover is None else takeover
    if takes_over and ((rskill is None and policy is None) or device is None):
        raise UsageError(
            "interventions: a policy (--rskill) and --teleop keyboard, gamepad[=NODE] or spacemouse[=NODE] "
            "(its takeover key or button)"
        )
    if device is not None:
        return DriverChoice(DriverKind.TAKEOVER if takes_over else DriverKind.PERSON, device, node)
    if teleop == LEADER:
        return DriverChoice(DriverKind.LEADER)
    return DriverChoice(DriverKind.CHECKPOINT if policy is not None else DriverKind.RSKILL)
