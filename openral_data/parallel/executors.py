"""Run worker jobs: local processes (`spawn`, so no simulator or GL state is inherited) or a Ray cluster.

Both return results in the order the workers finished; the caller orders episodes by seed, never by that.
"""

from __future__ import annotations

import multiprocessing
import os
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from typing import Any

from openral_data.errors import OpenralError
from openral_data.parallel.plan import WorkerJob
from openral_data.parallel.worker import WorkerResult, run_worker

EXECUTORS = ("local", "ray")
# environment a worker needs to find the same manifests and render the same way
_FORWARDED_ENV = ("OPENRAL_DATA_HOME", "MUJOCO_GL", "PYOPENGL_PLATFORM", "HF_HOME", "HF_HUB_OFFLINE", "SVT_LOG")


def run_local(jobs: list[WorkerJob]) -> list[WorkerResult]:
    ctx = multiprocessing.get_context("spawn")
    finished: list[WorkerResult] = []
    with ProcessPoolExecutor(max_workers=len(jobs), mp_context=ctx) as pool:
        pending = {pool.submit(run_worker, job) for job in jobs}
        while pending:
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                exc = fut.exception()
                if exc is not None:
                    for other in pending:
                        other.cancel()
                    raise exc
            finished += sorted((f.result() for f in done), key=lambda r: r.finished_at)
    return finished


def run_ray(jobs: list[WorkerJob], address: str | None = None) -> list[WorkerResult]:
    try:
        import ray
    except ImportError:
        raise OpenralError("--executor ray: Ray is not installed (install the `ray` extra)") from None
    started = False
    if not ray.is_initialized():
        env = {k: os.environ[k] for k in _FORWARDED_ENV if k in os.environ}
        kwargs: dict[str, Any] = {
            "include_dashboard": False,
            "log_to_driver": False,
            "runtime_env": {"env_vars": env},
        }
        if address is None:
            kwargs["num_cpus"] = max(len(jobs), os.cpu_count() or 1)
            # a busy machine can take longer than Ray's default 10 s for the local raylet to register
            os.environ.setdefault("RAY_raylet_start_wait_time_s", "120")
        try:
            ray.init(address=address, **kwargs)
        except (ConnectionError, RuntimeError) as exc:
            raise OpenralError(f"--address {address}: cannot connect to a Ray cluster: {exc}") from None
        started = True
    try:
        remote = ray.remote(num_cpus=1, max_retries=0)(run_worker)
        refs = [remote.remote(job) for job in jobs]
        finished: list[WorkerResult] = []
        while refs:
            ready, refs = ray.wait(refs, num_returns=1)
            try:
                finished.append(ray.get(ready[0]))
            except ray.exceptions.RayTaskError as exc:
                cause = getattr(exc, "cause", None)  # the worker's own exception
                if isinstance(cause, OpenralError):
                    raise OpenralError(str(cause)) from None
                raise
        return finished
    finally:
        if started:
            ray.shutdown()


def run_jobs(jobs: list[WorkerJob], executor: str = "local", address: str | None = None) -> list[WorkerResult]:
    if executor == "local":
        if address is not None:
            raise OpenralError("--address: only with --executor ray")
        return run_local(jobs)
    if executor == "ray":
        return run_ray(jobs, address)
    raise OpenralError(f"--executor: {executor!r} is not one of {', '.join(EXECUTORS)}")
