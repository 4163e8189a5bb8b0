"""The control loop's thread at real-time priority while an episode records (Linux `SCHED_FIFO`).

On 2 cores shared with the encoders, the cameras' capture threads and whatever else runs, the loop's own work is
small (a few ms a tick) but, ready to run, it waits its turn behind them; a real-time thread is run first, so its
ticks come on time while the encoders fall behind and spill (nothing is lost: `formats/lerobot_v3/video.py`). As
ros2_control's controller manager does, the recorder asks for `SCHED_FIFO` for the loop's thread alone, during an
episode only (between episodes, the commits and checks run at the normal policy), with `SCHED_RESET_ON_FORK` so a
thread it starts does not inherit it; where the system refuses (no `CAP_SYS_NICE`, no `RLIMIT_RTPRIO`, not Linux)
the loop runs as before and the refusal is said once. The kernel's real-time throttling (`sched_rt_runtime_us`)
still leaves the other threads 5 % of each core if the loop ever spun.
"""

from __future__ import annotations

import logging
import os

log = logging.getLogger(__name__)

DEFAULT_PRIORITY = 50  # ros2_control's default for its control thread (1..99)


class RealTime:
    """Promote and demote the calling thread; remembers a refusal so it is said once."""

    def __init__(self, priority: int) -> None:
        self.priority = priority
        self.refused: str | None = None

    def promote(self) -> bool:
        """`SCHED_FIFO` at `priority` for the calling thread; False (said once) where the system refuses."""
        if self.priority <= 0 or self.refused is not None:
            return False
        fifo = getattr(os, "SCHED_FIFO", None)
        if fifo is None or not hasattr(os, "sched_setscheduler"):
            self._refuse("this system has no SCHED_FIFO")
            return False
        reset = getattr(os, "SCHED_RESET_ON_FORK", 0)
        try:
            os.sched_setscheduler(0, fifo | reset, os.sched_param(self.priority))
        except OSError as exc:
            self._refuse(f"{exc.strerror or exc} (needs CAP_SYS_NICE or an RLIMIT_RTPRIO of {self.priority})")
            return False
        return True

    def demote(self) -> None:
        """Back to the normal policy (`SCHED_OTHER`)."""
        if hasattr(os, "sched_setscheduler"):
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))

    def _refuse(self, why: str) -> None:
        self.refused = why
        log.warning("the control loop runs at normal priority: real-time priority refused: %s", why)


def policy() -> int:
    """The calling thread's scheduling policy (without the reset-on-fork flag)."""
    return os.sched_getscheduler(0) & ~getattr(os, "SCHED_RESET_ON_FORK", 0)
