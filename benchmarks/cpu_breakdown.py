"""Per-stage, per-thread CPU accounting for bench_record_overhead.py's `--breakdown` mode.

`Stages` wraps methods so each call adds its thread CPU time (`time.thread_time`) to a stage, exclusive of
nested wrapped calls (a stage inside another is not counted twice); `ThreadSampler` polls `/proc/self/task`
for the CPU of threads Python does not run (llvmpipe's render threads, the codec's own worker threads), so
the process's CPU splits into: the main thread's stages, the encoder threads' stages, llvmpipe, and the
rest (codec-internal threads, ...). CPU time, not wall time: the machine may be shared.
"""

from __future__ import annotations

import functools
import os
import threading
import time
from collections import defaultdict
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

TICK = os.sysconf("SC_CLK_TCK")


class Stages:
    """Exclusive thread-CPU seconds per (thread kind, stage), for methods patched with `wrap`."""

    def __init__(self) -> None:
        self.cpu: dict[tuple[str, str], float] = defaultdict(float)
        self.calls: dict[tuple[str, str], int] = defaultdict(int)
        self._local = threading.local()
        self._undo: list[Callable[[], None]] = []

    def _kind(self) -> str:
        name = threading.current_thread().name
        return "main" if name == "MainThread" else name.split("-")[0]

    def wrap(self, owner: Any, attr: str, stage: str) -> None:
        original = getattr(owner, attr)

        @functools.wraps(original)
        def timed(*args: Any, **kwargs: Any) -> Any:
            stack: list[float] = self._local.__dict__.setdefault("stack", [])
            t0 = time.thread_time()
            stack.append(0.0)  # CPU of nested stages, subtracted from this one
            try:
                return original(*args, **kwargs)
            finally:
                spent = time.thread_time() - t0
                nested = stack.pop()
                key = (self._kind(), stage)
                self.cpu[key] += spent - nested
                self.calls[key] += 1
                if stack:
                    stack[-1] += spent

        setattr(owner, attr, timed)
        self._undo.append(lambda: setattr(owner, attr, original))

    def restore(self) -> None:
        while self._undo:
            self._undo.pop()()


def _task_cpu() -> dict[int, tuple[str, float]]:
    out: dict[int, tuple[str, float]] = {}
    for task in Path("/proc/self/task").iterdir():
        try:
            stat = (task / "stat").read_text()
            comm = (task / "comm").read_text().strip()
        except OSError:  # the thread ended meanwhile
            continue
        fields = stat[stat.rindex(")") + 2 :].split()
        out[int(task.name)] = (comm, (int(fields[11]) + int(fields[12])) / TICK)
    return out


class ThreadSampler:
    """Polls every thread's CPU (utime + stime) every `period` s; keeps each thread's last reading."""

    def __init__(self, period: float = 0.1) -> None:
        self.period = period
        self.own = 0.0  # this sampler's own CPU seconds (to subtract: it is not the code under test)
        self.last: dict[int, tuple[str, float]] = {}
        self._start: dict[int, float] = {}
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="sampler", daemon=True)

    def _run(self) -> None:
        t0 = time.thread_time()
        while not self._stop.wait(self.period):
            self.last.update(_task_cpu())
        self.own = time.thread_time() - t0

    @contextmanager
    def running(self) -> Iterator[ThreadSampler]:
        self._start = {tid: cpu for tid, (_, cpu) in _task_cpu().items()}
        self._thread.start()
        try:
            yield self
        finally:
            self._stop.set()
            self._thread.join()
            self.last.update(_task_cpu())

    def by_name(self, prefix: str) -> float:
        """CPU seconds used while running by the threads whose kernel name starts with `prefix`."""
        return sum(cpu - self._start.get(tid, 0.0) for tid, (comm, cpu) in self.last.items() if comm.startswith(prefix))
