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
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from openral_data.errors import HalError
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
            self.publish(CameraSample(image, time.monotonic(), seq))
            seq += 1

    @property
    def stopping(self) -> bool:
        """`stop()` was called: a capture waiting for its device gives up."""
        return self._stop.is_set()

    def publish(self, sample: CameraSample) -> None:
        """Make `sample` the newest (on the capture thread; a camera with a second stream extends it)."""
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


class LerobotCamera(ThreadedCamera):
    """A `lerobot.cameras` device (OpenCV: a device index or path, a video file, a network URL; RealSense; ZMQ)
    read on our own capture thread: `read()` blocks until the device's next frame, and the sample is stamped
    when it returned. Starting connects the device and waits up to `first_frame_timeout` seconds for a first
    frame, so a camera that never delivers fails before anything is recorded."""

    def __init__(
        self, name: str, shape: CameraShape, device: Any, source: str, field: str, first_frame_timeout: float = 5.0
    ) -> None:
        super().__init__(name, shape, self.read_frame)
        self.device = device
        self.source = source
        self.field = field
        self.first_frame_timeout = first_frame_timeout

    def read_frame(self) -> Image:
        """The device's next frame (on the capture thread), checked against the configured size."""
        while True:
            try:
                frame = np.asarray(self.device.read())
                break
            except TimeoutError:  # lerobot's 10 s wait ran out: a long stall; the loop counts the stale ticks
                if self._stop.is_set():
                    raise
        return self.checked(frame)

    def checked(self, frame: Image) -> Image:
        if frame.shape != (self.shape.height, self.shape.width, 3) or frame.dtype != np.uint8:
            raise HalError(
                f"{self.source}: {self.field}: a frame of {frame.shape} {frame.dtype}, the config says "
                f"{self.shape.height}x{self.shape.width} RGB uint8",
                code="hal.camera",
            )
        return frame

    def start(self) -> None:
        if self._thread is not None:
            return
        try:
            self.open_device()
        except (OSError, ConnectionError, RuntimeError, TimeoutError, ValueError) as exc:
            why = f"{exc} ({exc.__cause__})" if exc.__cause__ is not None else str(exc)  # the SDK's own words
            raise HalError(f"{self.source}: {self.field}: cannot open the camera: {why}", code="hal.camera") from None
        super().start()
        end = time.monotonic() + self.first_frame_timeout
        while self.latest() is None:
            if self.error is not None or time.monotonic() > end:
                why = f": {self.error}" if self.error is not None else ""
                self.stop()
                raise HalError(
                    f"{self.source}: {self.field}: no frame within {self.first_frame_timeout:.0f} s{why}",
                    code="hal.camera",
                )
            time.sleep(0.01)

    def open_device(self) -> None:
        """Connect the lerobot device (a camera with more to set up at connect time extends it)."""
        self.device.connect()

    def stop(self) -> None:
        super().stop()
        if getattr(self.device, "is_connected", False):
            self.device.disconnect()
