"""Each driver kind and the module that opens it: a new kind is one module plus its line in `OPENERS`."""

from __future__ import annotations

from collections.abc import Callable
from contextlib import ExitStack

from openral_data.record.drivers.base import DriveContext, Driver
from openral_data.record.drivers.checkpoint import open_checkpoint_driver
from openral_data.record.drivers.choice import DriverChoice, DriverKind
from openral_data.record.drivers.leader import open_leader
from openral_data.record.drivers.person import open_person
from openral_data.record.drivers.rskill import open_rskill
from openral_data.record.drivers.takeover import open_takeover

Opener = Callable[[DriverChoice, DriveContext, ExitStack], Driver]
OPENERS: dict[DriverKind, Opener] = {
    DriverKind.RSKILL: open_rskill,
    DriverKind.CHECKPOINT: open_checkpoint_driver,
    DriverKind.PERSON: open_person,
    DriverKind.LEADER: open_leader,
    DriverKind.TAKEOVER: open_takeover,
}


def open_driver(choice: DriverChoice, ctx: DriveContext, stack: ExitStack) -> Driver:
    """The driver `choice` names, open; what it opened closes with `stack`."""
    return OPENERS[choice.kind](choice, ctx, stack)
