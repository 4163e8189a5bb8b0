"""Camera sensors of a HAL: each hands out its newest sample with the monotonic time it was taken.

Sensors run at their own rate. `PolledCamera` captures when asked (a twin renders on the loop's thread);
`ThreadedCamera` captures on its own thread as fast as its source allows and keeps only the newest sample, so
a slow camera never stalls the control loop — the loop sees how old the sample is and decides (see
record/hal_loop.py).
Every sample carries a sequence number, so a reused sample is visible, never a silent duplicate.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import numpy.typing as npt

from openral_data.types import CameraShape

Image = npt.NDArray[np.uint8]


@dataclass(frozen=True)
class CameraSample:
    image: Image
    stamp: float  # time.monotonic() when captured
    seq: int  # 0, 1, 2, ... per sensor


class CameraSensor(Protocol):
    name: str
    shape: CameraShape

    def start(self) -> None: ...

    def stop(self) -> None: ...

    def latest(self) -> CameraSample | None:
        """The newest sample (None before the first); never waits for a new one."""
        ...


class PolledCamera:
    """Captures synchronously in `latest()` with `grab()`; the stamp is the capture time."""

    def __init__(self, name: str, shape: CameraShape, grab: Callable[[], Image]) -> None:
        self.name = name
        self.shape = shape
        self._grab = grab
        self._seq = 0

    def start(self) -> None:
        pass

    def stop(self) -> None:
        pass

    def latest(self) -> CameraSample | None:
        image = self._grab()
        sample = CameraSample(image, time.monotonic(), self._seq)
        self._seq += 1
        return sample


class ThreadedCamera:
    """Captures on a background thread (`grab()` may block for as long as the device needs)."""

    def __init__(self, name: str, shape: CameraShape, grab: Callable[[], Image]) -> None:
        self.name = name
        self.shape = shape
        self._grab = grab
        self._lock = threading.Lock()
        self._latest: CameraSample | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.error: BaseException | None = None

    def start(self) -> None:
        if self._thread is not None:
            return
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name=f"camera-{self.name}", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        seq = 0
        while not self._stop.is_set():
            try:
                image = self._grab()
            except BaseException as exc:  # noqa: BLE001 - reported through `error`; the loop sees a stale camera
                self.error = exc
                return
            sample = CameraSample(image, time.monotonic(), seq)
            seq += 1
            with self._lock:
                self._latest = sample

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
            self._thread = None

    def latest(self) -> CameraSample | None:
        with self._lock:
            return self._latest
