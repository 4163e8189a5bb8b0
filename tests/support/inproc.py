"""The real `openral-data` entry point (`cli.app.main`, with its error handling) run in this process: fast
enough for hundreds of malformed-input cases, where a subprocess each would take seconds."""

from __future__ import annotations

import io
import sys
import traceback
from contextlib import redirect_stderr, redirect_stdout
from dataclasses import dataclass


@dataclass(frozen=True)
class Run:
    returncode: int
    stdout: str
    stderr: str


def run_inproc(*args: str) -> Run:
    """`openral-data ARGS` through `main()`; an exception escaping it is printed as the interpreter would
    (a `Traceback` on stderr, exit 1), so a bug looks the same as in a subprocess."""
    from openral_data.cli.app import main

    out, err = io.StringIO(), io.StringIO()
    old_argv = sys.argv
    sys.argv = ["openral-data", *args]
    code = 0
    try:
        with redirect_stdout(out), redirect_stderr(err):
            try:
                main()
            except SystemExit as exc:
                code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
            except BaseException:  # noqa: BLE001  # a bug: report it as the interpreter would
                traceback.print_exc(file=err)
                code = 1
    finally:
        sys.argv = old_argv
    return Run(code, out.getvalue(), err.getvalue())
