"""One process or N: the choice every command that takes `--workers N [--executor local|ray]` makes (`record`,
`convert`, `generate`, a pipeline's record step), made here once; and how N workers share the work
(`contiguous_blocks`: record's episodes, convert's bags and files)."""

from __future__ import annotations

from openral_data.errors import UsageError


def is_parallel(workers: int, executor: str = "local") -> bool:
    """Whether the run goes to workers (`--workers` other than 1, or an executor other than this process's
    `local`); a `--workers` below 1 is refused by the parallel run itself (one line, before any work)."""
    return workers != 1 or executor != "local"


def check_workers(workers: int) -> None:
    """A `--workers` below 1 is one line, before any work."""
    if workers < 1:
        raise UsageError(f"--workers must be >= 1, got {workers}")


def contiguous_blocks(n: int, workers: int) -> list[range]:
    """At most `workers` contiguous, near-equal blocks of 0..n-1, in order (the first ones one longer)."""
    check_workers(workers)
    parts = min(workers, n)
    blocks: list[range] = []
    start = 0
    for w in range(parts):
        count = n // parts + (1 if w < n % parts else 0)
        blocks.append(range(start, start + count))
        start += count
    return blocks
