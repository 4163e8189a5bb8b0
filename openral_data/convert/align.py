"""Streaming multi-rate alignment of timestamped samples onto a fixed-rate frame grid.

Samples arrive in time order across all streams (as a bag reader yields them). The grid starts when every
stream has delivered a sample (``t0``) and advances by ``1/fps``. Frame ``k`` at ``T = t0 + k/fps`` takes,
per stream, either the latest sample at or before ``T`` (``previous``) or the sample closest to ``T``
(``nearest``, ties go to the earlier one), if that sample is at most ``max_staleness`` away; otherwise the
frame cannot be filled and is reported as such, never filled with zeros or stale data.

Memory is bounded: a frame is decided as soon as no later sample can change it (time > T for previous,
> T + max_staleness for nearest), and samples that can no longer serve any frame are released. What is held
is the samples of roughly ``max_staleness`` (plus one frame period) per stream.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Literal

Method = Literal["previous", "nearest"]


@dataclass(frozen=True)
class AlignedFrame[P]:
    """Frame `index` of the grid at `time_ns`; `samples` holds one payload per stream, or None if unfillable."""

    index: int
    time_ns: int
    samples: dict[str, P] | None
    missing: tuple[str, ...] = ()  # streams with no sample within max_staleness


@dataclass
class AlignStats:
    frames: int = 0
    unfillable: dict[str, int] = field(default_factory=dict)  # stream -> frames it could not fill
    unused: dict[str, int] = field(default_factory=dict)  # stream -> samples no frame took
    received: dict[str, int] = field(default_factory=dict)


class Aligner[P]:
    def __init__(self, streams: list[str], fps: int, method: Method, max_staleness: float) -> None:
        self.streams = list(streams)
        self.period_ns = 1_000_000_000 / fps
        self.method: Method = method
        self.stale_ns = round(max_staleness * 1e9)
        self._buf: dict[str, deque[tuple[int, P, list[bool]]]] = {s: deque() for s in self.streams}
        self.t0: int | None = None
        self._k = 0
        self.stats = AlignStats(received=dict.fromkeys(self.streams, 0))

    def _frame_time(self, k: int) -> int:
        assert self.t0 is not None
        return self.t0 + round(k * self.period_ns)

    def push(self, stream: str, time_ns: int, payload: P) -> Iterator[AlignedFrame[P]]:
        """Add a sample; yield every frame that became decidable before it."""
        self.stats.received[stream] += 1
        if self.t0 is not None:
            yield from self._decide_until(time_ns)
        self._buf[stream].append((time_ns, payload, [False]))
        if self.t0 is None:
            for s, buf in self._buf.items():  # before the grid starts only recent samples can matter
                while len(buf) > 1 and buf[0][0] < time_ns - self.stale_ns:
                    self._release(s, buf.popleft())
            if all(self._buf.values()):
                self.t0 = time_ns

    def finish(self) -> Iterator[AlignedFrame[P]]:
        """End of the stream: decide the remaining frames up to the last sample of any stream."""
        if self.t0 is not None:
            last = max((buf[-1][0] for buf in self._buf.values() if buf), default=self.t0)
            while self._frame_time(self._k) <= last:
                yield self._decide(self._k)
                self._k += 1
        for s, buf in self._buf.items():
            while buf:
                self._release(s, buf.popleft())

    def _decide_until(self, now_ns: int) -> Iterator[AlignedFrame[P]]:
        horizon = 0 if self.method == "previous" else self.stale_ns
        while self._frame_time(self._k) + horizon < now_ns:
            yield self._decide(self._k)
            self._k += 1

    def _decide(self, k: int) -> AlignedFrame[P]:
        t = self._frame_time(k)
        chosen: dict[str, P] = {}
        missing: list[str] = []
        for s, buf in self._buf.items():
            best: tuple[int, P, list[bool]] | None = None
            for sample in buf:
                dt = sample[0] - t
                if self.method == "previous":
                    if dt > 0:
                        break
                    best = sample
                elif best is None or abs(dt) < abs(best[0] - t):
                    best = sample
            if best is None or abs(best[0] - t) > self.stale_ns:
                missing.append(s)
            else:
                chosen[s] = best[1]
                best[2][0] = True
            # samples before the next frame's window can serve no later frame
            keep_from = self._frame_time(k + 1) - self.stale_ns
            while len(buf) > 1 and buf[1][0] <= keep_from:
                self._release(s, buf.popleft())
        self.stats.frames += 1
        if missing:
            for s in missing:
                self.stats.unfillable[s] = self.stats.unfillable.get(s, 0) + 1
            return AlignedFrame(k, t, None, tuple(missing))
        return AlignedFrame(k, t, chosen)

    def _release(self, stream: str, sample: tuple[int, P, list[bool]]) -> None:
        if not sample[2][0]:
            self.stats.unused[stream] = self.stats.unused.get(stream, 0) + 1
