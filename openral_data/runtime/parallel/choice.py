"""One process or N: the choice every command that takes `--workers N [--executor local|ray]` makes (`record`,
`convert`, `generate`, a pipeline's record step), made here once."""

from __future__ import annotations


def is_parallel(workers: int, executor: str = "local") -> bool:
    """Whether the run goes to workers (`--workers` other than 1, or an executor other than this process's
    `local`); a `--workers` below 1 is refused by the parallel run itself (one line, before any work)."""
    return workers != 1 or executor != "local"
