"""Timing shared by the overhead benchmarks (bench_replay.py, bench_record_overhead.py): a stopwatch over wall
and process CPU time, the alternating baseline-vs-contestant loop whose medians give the overhead, and the
lines they print (`digits` decimals of seconds)."""

from __future__ import annotations

import resource
import statistics
import subprocess
import time
from collections.abc import Callable
from types import TracebackType

Timing = tuple[float, float, int]  # wall seconds, CPU seconds of the whole process (all threads), work done


class Stopwatch:
    """`with Stopwatch() as sw:` measures the block's wall and process CPU time (`sw.timing(work)`)."""

    def __init__(self) -> None:
        self.wall = self.cpu = 0.0
        self._t0 = self._c0 = 0.0

    def __enter__(self) -> Stopwatch:
        self._t0, self._c0 = time.perf_counter(), time.process_time()
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self.wall, self.cpu = time.perf_counter() - self._t0, time.process_time() - self._c0

    def timing(self, work: int) -> Timing:
        return self.wall, self.cpu, work


def run_child(
    cmd: list[str], env: dict[str, str] | None = None
) -> tuple[subprocess.CompletedProcess[str], float, float]:
    """`cmd` run to its end (output captured): the result, its wall seconds and its CPU seconds (user + system
    of the child, from `getrusage`; run one child at a time)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True, check=False, env=env)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return done, wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def alternate(
    repeats: int,
    baseline: Callable[[], Timing],
    contestant: Callable[[], Timing],
    on_run: Callable[[int, Timing, Timing], None],
) -> tuple[list[Timing], list[Timing]]:
    """Run baseline then contestant `repeats` times, alternating; `on_run(k, baseline's, contestant's)` after
    each pair (to check the work matches and print the run)."""
    base: list[Timing] = []
    other: list[Timing] = []
    for k in range(repeats):
        base.append(baseline())
        other.append(contestant())
        on_run(k, base[-1], other[-1])
    return base, other


def medians(runs: list[Timing]) -> tuple[float, float]:
    """Median wall and median CPU seconds of the runs."""
    return statistics.median(t[0] for t in runs), statistics.median(t[1] for t in runs)


def run_line(k: int, base: Timing, other: Timing, name: str, unit: str, digits: int) -> str:
    """One pair of runs: both times, the contestant's work done and its overhead."""
    (tb, cb, _), (tr, cr, n) = base, other
    return (
        f"run {k + 1}: baseline {tb:.{digits}f} s wall / {cb:.{digits}f} s CPU, "
        f"{name} {tr:.{digits}f} s / {cr:.{digits}f} s, "
        f"{n} {unit}, overhead {tr / tb - 1:+.1%} wall / {cr / cb - 1:+.1%} CPU"
    )


def overhead_table(header: str, cpu_label: str, base: list[Timing], other: list[Timing], digits: int) -> str:
    """The Markdown table of median wall and CPU times and the overhead; `header` names the columns."""
    (b, bc), (r, rc) = medians(base), medians(other)
    return (
        f"{header}\n|---|---|---|---|\n"
        f"| wall | {b:.{digits}f} s | {r:.{digits}f} s | {r / b - 1:+.1%} |\n"
        f"| {cpu_label} | {bc:.{digits}f} s | {rc:.{digits}f} s | {rc / bc - 1:+.1%} |"
    )
