"""Crash a driver process at one exact filesystem mutation, as a SIGKILL would land there.

`die_at_mutation` wraps `os.replace`, `os.rename`, `os.unlink` and `os.remove` (`Path.replace/rename/unlink`
and `shutil.rmtree` go through them) for the rest of the process. It numbers the calls it counts from 1;
on the `die_at`-th it exits at once (`os._exit(137)`: no cleanup, no flush, as SIGKILL) instead of doing it.
`name` counts only the calls whose target (the destination of a rename, the path unlinked) has that file
name; `report(i, op, target)` is called after each counted call is done. Returns how many were counted so
far, when called.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

OPS = ("replace", "rename", "unlink", "remove")
KILLED = 137


def die_at_mutation(
    die_at: int | None,
    *,
    ops: tuple[str, ...] = OPS,
    name: str | None = None,
    report: Callable[[int, str, Path], None] | None = None,
) -> Callable[[], int]:
    seen = [0]

    def wrap(op: str, real: Callable[..., Any]) -> Callable[..., Any]:
        def mutate(*args: Any, **kwargs: Any) -> Any:
            target = Path(args[1] if op in ("replace", "rename") else args[0])
            if name is not None and target.name != name:
                return real(*args, **kwargs)
            seen[0] += 1
            if seen[0] == die_at:
                os._exit(KILLED)
            out = real(*args, **kwargs)
            if report is not None:
                report(seen[0], op, target)
            return out

        return mutate

    for op in ops:
        setattr(os, op, wrap(op, getattr(os, op)))
    return lambda: seen[0]
