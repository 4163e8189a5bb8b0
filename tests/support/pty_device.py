"""The serial end of a SIMULATED motor bus for tests: a pseudo-terminal whose far end a Python thread serves.

A servo bus SDK (the scservo SDK for Feetech, dynamixel_sdk for Dynamixel) opens `port` with pyserial as it would a
USB adapter; a subclass's `parse` takes the bytes the SDK wrote (`self.buffer`) and answers through `reply`.

A servo answers within microseconds; this thread is Python on a loaded 2-core CI machine that can be held off for
longer than the SDKs' packet timeouts (≈ 34–50 ms). While a bus is open, the SDK's timeout check (its
`PortHandler.isPacketTimeout`, the same in both SDKs) gets `TIMEOUT_SLACK_MS` of extra patience, so a late
simulated reply is not taken for a missing servo.
"""

from __future__ import annotations

import os
import select
import threading
import time
import tty
from typing import Any, Self

TIMEOUT_SLACK_MS = 1000.0


class PtyDevice:
    """Serves a protocol on a pty; `port` is the path the driver opens; `port_handler` is the SDK's PortHandler
    class whose timeout check gets the slack while this device is open."""

    def __init__(self, name: str, port_handler: type[Any]) -> None:
        self._master, slave = os.openpty()
        tty.setraw(slave)
        self.port = os.ttyname(slave)
        self._slave = slave
        self._stop = threading.Event()
        self.buffer = bytearray()
        self.reply_delay_s = 0.0  # how long the device takes to answer (a USB adapter's latency: milliseconds)
        self._port_handler = port_handler
        self._original_timeout_check = port_handler.isPacketTimeout
        port_handler.isPacketTimeout = patient_is_packet_timeout
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    def parse(self) -> None:
        """Consume the complete packets at the start of `self.buffer` and answer them."""
        raise NotImplementedError

    def reply(self, data: bytes) -> None:
        if self.reply_delay_s:
            time.sleep(self.reply_delay_s)
        os.write(self._master, data)

    def close(self) -> None:
        self._port_handler.isPacketTimeout = self._original_timeout_check
        self._stop.set()
        self._thread.join(timeout=5)
        os.close(self._master)
        os.close(self._slave)

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _run(self) -> None:
        while not self._stop.is_set():
            ready, _, _ = select.select([self._master], [], [], 0.05)
            if not ready:
                continue
            try:
                self.buffer += os.read(self._master, 4096)
            except OSError:
                return
            self.parse()


def patient_is_packet_timeout(self: Any) -> bool:
    """The SDKs' own check (PortHandler.isPacketTimeout) with TIMEOUT_SLACK_MS more patience."""
    if self.getTimeSinceStart() > self.packet_timeout + TIMEOUT_SLACK_MS:
        self.packet_timeout = 0
        return True
    return False
