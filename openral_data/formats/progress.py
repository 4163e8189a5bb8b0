"""The ambient progress of long work: `(done, total)` reported by loops that take seconds (an edit writing
episodes, `doctor --deep` decoding videos) to whoever set `PROGRESS` (the CLI's progress bar, cli/globalflags.py).
Unset, nothing is reported; the loops never depend on it."""

from __future__ import annotations

from collections.abc import Callable
from contextvars import ContextVar

PROGRESS: ContextVar[Callable[[int, int], None] | None] = ContextVar("openral_progress", default=None)


def tick(done: int, total: int) -> None:
    """Report `done` of `total` to the current listener, if any."""
    listener = PROGRESS.get()
    if listener is not None:
        listener(done, total)
