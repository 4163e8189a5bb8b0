"""Run a driver module (`python -m MODULE ARG`: its `main()` reads `sys.argv[1]`) again and again, each run in a
child forked from one server process that imported the module once, instead of a fresh interpreter per run.

A run is the same process a fresh `python -m MODULE ARG` would be from the moment `main()` starts: its own pid,
address space and exit status (`os._exit(137)` at a crash point included); only the imports (and `warm_up()`,
if the module has one) were done before the fork. The server (`python -m tests.support.forked MODULE`) reads
one JSON request a line (`{"arg": ..., "stdout": PATH, "stderr": PATH}`), forks, and answers `exit CODE` once
the child ended; no Python thread of it runs when it forks.

`Forked(MODULE)` (a context manager) starts the server from the repository root; `run(arg)` returns the exit
code, stdout and stderr of one run, as `subprocess.run(..., capture_output=True, text=True)` would.
"""

from __future__ import annotations

import importlib
import json
import os
import select
import signal
import subprocess
import sys
import tempfile
import threading
import traceback
import warnings
from pathlib import Path
from types import ModuleType, TracebackType

from tests.support.home import REPO


def _child(module: ModuleType, request: dict[str, str]) -> int:
    """In the forked child: point fds 1 and 2 at the request's files, run `main()`, return its exit status."""
    for fd, key in ((1, "stdout"), (2, "stderr")):
        target = os.open(request[key], os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
        os.dup2(target, fd)
        os.close(target)
    sys.argv = [module.__name__, request["arg"]]
    try:
        module.main()
        code = 0
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    except BaseException:  # noqa: BLE001 - as the interpreter would: a traceback on stderr, status 1
        traceback.print_exc()
        code = 1
    for thread in threading.enumerate():  # as interpreter shutdown does: wait for the non-daemon threads
        if thread is not threading.main_thread() and not thread.daemon:
            thread.join()
    sys.stdout.flush()
    sys.stderr.flush()
    return code


def serve(name: str) -> None:
    module = importlib.import_module(name)
    warm_up = getattr(module, "warm_up", None)
    if warm_up is not None:
        warm_up()
    assert threading.active_count() == 1, f"{name}'s import left threads running: {threading.enumerate()}"
    for line in sys.stdin:
        request = json.loads(line)
        sys.stdout.flush()
        sys.stderr.flush()
        with warnings.catch_warnings():
            # numpy's OpenBLAS pool and pyarrow's jemalloc keep native threads; both register fork handlers
            # (pthread_atfork), and no Python thread runs here (asserted above)
            warnings.simplefilter("ignore", DeprecationWarning)
            pid = os.fork()
        if pid == 0:
            code = 1
            try:
                code = _child(module, request)
            finally:
                os._exit(code)
        _, status = os.waitpid(pid, 0)
        print(f"exit {os.waitstatus_to_exitcode(status)}", flush=True)


class Forked:
    """A server for driver `module`, started from the repository root; `run(arg)` is one run of the driver."""

    def __init__(self, module: str) -> None:
        self.module = module
        self.scratch = tempfile.TemporaryDirectory(prefix="forked-")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "tests.support.forked", module],
            cwd=REPO,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            start_new_session=True,  # its own process group: a run past its timeout is killed with it
        )
        self.runs = 0

    def run(self, arg: str, timeout: float = 300) -> tuple[int, str, str]:
        """Exit code, stdout and stderr of `python -m MODULE ARG`, run in a forked child of the server."""
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.runs += 1
        out, err = (Path(self.scratch.name) / f"{self.runs}.{key}" for key in ("out", "err"))
        request = {"arg": arg, "stdout": str(out), "stderr": str(err)}
        self.proc.stdin.write(json.dumps(request) + "\n")
        self.proc.stdin.flush()
        ready, _, _ = select.select([self.proc.stdout], [], [], timeout)
        if not ready:
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.close()
            raise TimeoutError(f"{self.module} {arg}: no exit after {timeout} s")
        reply = self.proc.stdout.readline()
        assert reply.startswith("exit "), f"the {self.module} server answered {reply!r} (exit {self.proc.poll()})"
        code = int(reply.split()[1])
        return code, out.read_text(), err.read_text()

    def close(self) -> None:
        if self.proc.stdin is not None:
            self.proc.stdin.close()
        try:
            self.proc.wait(timeout=60)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        if self.proc.stdout is not None:
            self.proc.stdout.close()
        self.scratch.cleanup()

    def __enter__(self) -> Forked:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        self.close()


if __name__ == "__main__":
    serve(sys.argv[1])
