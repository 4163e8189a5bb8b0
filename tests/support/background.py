"""A simulated device's or person's loop on a daemon thread, started and stopped as a context manager."""

from __future__ import annotations

import threading
from typing import Self


class Background:
    """`run` on a daemon thread from `__enter__` until `__exit__`; `run` polls `stopping()` and returns when it is
    true."""

    def __init__(self, name: str | None = None) -> None:
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self.run, name=name, daemon=True)

    def run(self) -> None:
        raise NotImplementedError

    def stopping(self) -> bool:
        return self._stop.is_set()

    def __enter__(self) -> Self:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()
