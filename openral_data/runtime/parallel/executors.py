"""Run worker jobs: local processes (`spawn`, so no simulator or GL state is inherited) or a Ray cluster.

Both return results in the order the workers finished; the caller orders its output by the jobs (seed, bag
order), never by that. `record --workers` runs `openral_data.record.parallel.worker.run_worker` on its
`plan.WorkerJob`s and `convert --workers` its own job function on its own jobs, each with its own initializer.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from multiprocessing.queues import SimpleQueue
from typing import Any, Protocol

from openral_data import manifests
from openral_data.errors import ExecutorError, OpenralError, UsageError
from openral_data.runtime.parallel.channel import START_HELD, STOP_HELD, held, start_worker

EXECUTORS = ("local", "ray")


class Finished(Protocol):
    """What a job function returns: at least when its work was complete (results are listed in that order)."""

    @property
    def finished_at(self) -> float: ...


# environment a worker needs to find the same manifests and render the same way
_FORWARDED_ENV = (
    *manifests.ENV_DIRS.values(),
    "OPENRAL_DATA_CONFIG",
    "XDG_CONFIG_HOME",
    "MUJOCO_GL",
    "PYOPENGL_PLATFORM",
    "HF_HOME",
    "HF_HUB_OFFLINE",
    "SVT_LOG",
)


def run_local[J, R: Finished](
    jobs: list[J],
    fn: Callable[[J], R],
    initializer: Callable[[], None],
    on_finished: Callable[[R], None] | None = None,
    on_report: Callable[[Any], None] | None = None,
) -> list[R]:
    ctx = multiprocessing.get_context("spawn")
    reports = ctx.SimpleQueue() if on_report is not None else None
    finished: list[R] = []
    with ProcessPoolExecutor(
        max_workers=len(jobs), mp_context=ctx, initializer=start_worker, initargs=(initializer, reports)
    ) as pool:
        pending: set[Future[R]] = set()
        try:
            with held(START_HELD):  # the workers start (on submit) with these blocked: see channel.py
                pending = {pool.submit(fn, job) for job in jobs}
            while pending:
                poll = None if reports is None else _POLL_S
                done, pending = wait(pending, timeout=poll, return_when=FIRST_COMPLETED)
                _drain(reports, on_report)  # before the results: a job reports before it returns
                for fut in done:
                    exc = fut.exception()
                    if exc is not None:
                        raise exc
                for result in sorted((f.result() for f in done), key=lambda r: r.finished_at):
                    finished.append(result)
                    if on_finished is not None:
                        on_finished(result)
        except BaseException:
            # a failed worker or Ctrl-C: stop the others the way Ctrl-C stops `record` (the episode in flight is
            # discarded, finished ones stay durable in each worker's dataset) instead of waiting for their shares
            with held(STOP_HELD):
                for fut in pending:
                    fut.cancel()
                _interrupt(pool)
                pool.shutdown(wait=True)
            raise
    return finished


_POLL_S = 0.1  # how often the parent reads the workers' reports while it waits for results


def _drain(reports: SimpleQueue[Any] | None, on_report: Callable[[Any], None] | None) -> None:
    if reports is None or on_report is None:
        return
    while not reports.empty():
        on_report(reports.get())


def _interrupt(pool: ProcessPoolExecutor) -> None:
    processes: dict[int, Any] = getattr(pool, "_processes", None) or {}
    for proc in list(processes.values()):
        if proc.is_alive() and proc.pid is not None:
            with contextlib.suppress(ProcessLookupError):
                os.kill(proc.pid, signal.SIGTERM)  # a second SIGINT would not wait for a commit


def run_ray[J, R: Finished](
    jobs: list[J],
    fn: Callable[[J], R],
    address: str | None = None,
    on_finished: Callable[[R], None] | None = None,
) -> list[R]:
    try:
        import ray
    except ImportError:
        raise ExecutorError("--executor ray: Ray is not installed (install the `ray` extra)") from None
    started = False
    if not ray.is_initialized():
        env = {k: os.environ[k] for k in _FORWARDED_ENV if k in os.environ}
        env["OPENRAL_DATA_HOME"] = str(manifests.project_dir())  # a Ray worker runs in a folder of Ray's own
        kwargs: dict[str, Any] = {
            "include_dashboard": False,
            "log_to_driver": False,
            "runtime_env": {"env_vars": env},
        }
        if address is None:
            kwargs["num_cpus"] = max(len(jobs), os.cpu_count() or 1)
        _init_ray(ray, address, kwargs)
        started = True
    try:
        remote = ray.remote(num_cpus=1, max_retries=0)(fn)
        refs = [remote.remote(job) for job in jobs]
        finished: list[R] = []
        try:
            while refs:
                ready, refs = ray.wait(refs, num_returns=1)
                try:
                    result = ray.get(ready[0])
                except ray.exceptions.RayTaskError as exc:
                    cause = getattr(exc, "cause", None)  # the worker's own exception
                    if isinstance(cause, OpenralError):
                        raise cause.amended(str(cause)) from None
                    raise
                finished.append(result)
                if on_finished is not None:
                    on_finished(result)
        except BaseException:
            for ref in refs:  # a failed task or Ctrl-C: the others stop too (on a cluster, shutdown would not)
                with contextlib.suppress(Exception):
                    ray.cancel(ref, force=True)
            raise
        return finished
    finally:
        if started:
            ray.shutdown()


def _init_ray(ray: Any, address: str | None, kwargs: dict[str, Any]) -> None:
    """Connect to `address`, or start a local instance. On a loaded machine Ray's local start can give up
    (its raylet waits a fixed 15 s for the agent's port file, ray-project/ray#65983): retry that twice."""
    attempts = 1 if address is not None else 3
    for attempt in range(1, attempts + 1):
        try:
            ray.init(address=address, **kwargs)
            return
        except Exception as exc:  # noqa: BLE001 - Ray reports a failed start as a bare Exception
            ray.shutdown()
            if address is not None:
                raise ExecutorError(f"--address {address}: cannot connect to a Ray cluster: {exc}") from None
            if attempt == attempts or "timed out during startup" not in str(exc):
                raise ExecutorError(f"--executor ray: could not start a local Ray instance: {exc}") from None


def check_executor(executor: str, address: str | None = None) -> None:
    """The executor's name and --address, checked before any work starts (exit 2, one line)."""
    if executor not in EXECUTORS:
        raise UsageError(f"--executor: {executor!r} is not one of {', '.join(EXECUTORS)}")
    if executor == "local" and address is not None:
        raise UsageError("--address: only with --executor ray")


def run_on[J, R: Finished](
    jobs: list[J],
    fn: Callable[[J], R],
    executor: str = "local",
    address: str | None = None,
    *,
    initializer: Callable[[], None],
    on_finished: Callable[[R], None] | None = None,
    on_report: Callable[[Any], None] | None = None,
) -> list[R]:
    """Run `fn(job)` for every job, each in its own process (`local`) or Ray task (`ray`).

    `on_finished(result)` runs in this process as each job's result comes back; `on_report(item)` for each item
    a job sent with `channel.report` while it ran (local only: under Ray a job reports nothing)."""
    check_executor(executor, address)
    if executor == "local":
        return run_local(jobs, fn, initializer, on_finished, on_report)
    return run_ray(jobs, fn, address, on_finished)
