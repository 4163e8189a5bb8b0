"""The start of a run: build the scene and load the policy at the same time, and log how long each took.

The policy load (a checkpoint read, a model built) does not need the scene, so it runs in a worker thread while
the main thread builds the scene and checks it against the rSkill. The scene stays on the main thread, the one
that steps and renders it later (an EGL/GL context belongs to the thread that made it). `OPENRAL_SEQUENTIAL_START=1`
forces the old order (scene, check, policy), for profiling.

Errors are the ones the sequential order raises: a scene error first, then the check's, then the policy's; the
part that did start is closed before the error goes up.
"""

from __future__ import annotations

import contextlib
import logging
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

SEQUENTIAL_ENV = "OPENRAL_SEQUENTIAL_START"

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Started[S, P]:
    scene: S
    policy: P
    env_ms: float  # building the scene
    policy_ms: float  # loading the policy
    total_ms: float  # both ready and checked
    concurrent: bool


def sequential() -> bool:
    return os.environ.get(SEQUENTIAL_ENV, "").strip() not in ("", "0")


def _ms(since: float) -> float:
    return round((time.perf_counter() - since) * 1000, 1)


class _PolicyLoad[P]:
    """`load()` in a worker thread; `result()` joins it and returns the policy or raises its error."""

    def __init__(self, load: Callable[[], P]) -> None:
        self._load = load
        self._policy: P | None = None
        self._error: BaseException | None = None
        self.ms = 0.0
        self._thread = threading.Thread(target=self._run, name="policy-load", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        t0 = time.perf_counter()
        try:
            self._policy = self._load()
        except BaseException as exc:  # noqa: BLE001 - handed to the main thread by result()
            self._error = exc
        self.ms = _ms(t0)

    def result(self) -> P:
        self._thread.join()
        if self._error is not None:
            raise self._error
        assert self._policy is not None
        return self._policy

    def discard(self, close: Callable[[P], None]) -> None:
        """The run failed elsewhere: wait for the load, close what it made, drop its error (not the first one)."""
        self._thread.join()
        if self._policy is not None:
            with contextlib.suppress(Exception):
                close(self._policy)


def start[S, P](
    build_scene: Callable[[], S],
    check: Callable[[S], None],
    load_policy: Callable[[], P],
    close_scene: Callable[[S], None],
    close_policy: Callable[[P], None],
) -> Started[S, P]:
    """The scene (built and checked on this thread) and the policy (loaded beside it), with their timings logged."""
    concurrent = not sequential()
    t0 = time.perf_counter()
    loading = _PolicyLoad(load_policy) if concurrent else None
    try:
        scene = build_scene()
    except Exception:
        if loading is not None:
            loading.discard(close_policy)
        raise
    env_ms = _ms(t0)
    log.info("scene built in %.0f ms", env_ms, extra={"env_ms": env_ms})
    try:
        check(scene)
        t1 = time.perf_counter()
        policy = loading.result() if loading is not None else load_policy()
        policy_ms = loading.ms if loading is not None else _ms(t1)
    except Exception:
        if loading is not None:
            loading.discard(close_policy)
        with contextlib.suppress(Exception):
            close_scene(scene)
        raise
    total_ms = _ms(t0)
    log.info("policy loaded in %.0f ms", policy_ms, extra={"policy_ms": policy_ms})
    log.info(
        "started in %.0f ms (%s)",
        total_ms,
        "concurrent" if concurrent else "sequential",
        extra={"env_ms": env_ms, "policy_ms": policy_ms, "total_ms": total_ms, "concurrent": concurrent},
    )
    return Started(scene, policy, env_ms, policy_ms, total_ms, concurrent)
