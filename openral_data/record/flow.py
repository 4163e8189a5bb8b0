"""The episode flow for a person at the robot (`record --hal`, `record --teleop`): how long an episode records
(`--episode-time-s`), the time to reset the scene between episodes (`--reset-time-s`, space skips it), and the
lines that tell the person what comes next and what was decided.

An episode of S seconds is the ticks due in its first S seconds: `round(S * fps)` ticks, so `round(S * fps)`
frames when no tick was missed or stale (the loop's accounting, record/hal_loop.py). During the reset nothing is
sent to the robot and nothing is recorded: the servos hold their last goal position.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from openral_data.errors import UsageError
from openral_data.producers.hal.session.operator import Command, Operator
from openral_data.schemas.scene import MAX_STEPS

Notify = Callable[[str], None]  # one line for the person: which episode, what happened to it


def episode_ticks(episode_time_s: float | None, fps: int) -> int | None:
    """The ticks an episode of `episode_time_s` seconds lasts at `fps` (None: no time limit); refused, before
    anything is written, when not a positive finite time of at least one frame."""
    if episode_time_s is None:
        return None
    if not 0 < episode_time_s < math.inf:
        raise UsageError(f"--episode-time-s must be > 0 and finite, got {episode_time_s}")
    if episode_time_s * fps > MAX_STEPS:  # before round(): 1e308 s would overflow it
        raise UsageError(
            f"--episode-time-s: {episode_time_s} s is more than {MAX_STEPS} frames at {fps} fps (an episode's most)"
        )
    ticks = round(episode_time_s * fps)
    if ticks < 1:
        raise UsageError(f"--episode-time-s: {episode_time_s} s is less than one frame at {fps} fps")
    return ticks


def check_reset_time(reset_time_s: float | None) -> None:
    if reset_time_s is not None and not 0 < reset_time_s < math.inf:
        raise UsageError(f"--reset-time-s must be > 0 and finite, got {reset_time_s}")


@dataclass(frozen=True)
class Flow:
    """The prompts of one run: `n` episodes of `task`, each `episode_time_s` long (None: until the step limit, the
    scene's end or a key), `reset_time_s` between them (None: no reset wait). `notify` None: say nothing."""

    n: int
    task: str
    notify: Notify | None = None
    episode_time_s: float | None = None
    reset_time_s: float | None = None

    def say(self, line: str) -> None:
        if self.notify is not None:
            self.notify(line)

    def name(self, index: int) -> str:
        """`episode 2/5`: the person counts from 1; the dataset's `episode_index` is `index` (from 0)."""
        return f"episode {index + 1}/{self.n}"

    def ask_start(self, index: int, interactive: bool) -> None:
        if interactive:
            self.say(f"{self.name(index)}: {self.task} — press space to start (q quits)")

    def started(self, index: int, again: bool) -> None:
        timer = f", {self.episode_time_s:g} s" if self.episode_time_s is not None else ""
        self.say(f"{self.name(index)}: recording{' again' if again else ''}{timer} — {self.task}")

    def reset(self, operator: Operator, index: int, check: Callable[[], None]) -> Command | None:
        """The reset wait before episode `index`: a countdown each whole second until `reset_time_s` passed
        (None), the person skips it (START), quits (QUIT) or trips the e-stop (ESTOP). Nothing is sent to the robot
        meanwhile."""
        if self.reset_time_s is None:
            return None
        left = self.reset_time_s
        self.say(f"reset: {left:g} s to reset the scene — space starts {self.name(index)} now (q quits)")
        while left > 0:
            chunk = left - math.ceil(left) + 1  # to the next whole second left
            cmd = operator.pause(chunk, check)
            if cmd is not None:
                return cmd
            left = round(left - chunk, 6)
            if left > 0:
                self.say(f"reset: {left:g} s")
        return None
