"""Every `stride`-th frame of a video span, or any set of its frames, decoded without decoding the rest where the
stream allows it.

An mp4's keyframe (a sync sample) is a random access point: decoding may start there, and every frame shown from
it on needs nothing before it. Only the frames that follow it in decode order but are shown before it (an open
GOP's leading B-frames) may refer back. So the packets not sent to the decoder yet are held, and those before
the last keyframe dropped once a packet shown after that keyframe arrives; when a wanted frame's packet arrives,
the held packets are sent, in decode order. A group of pictures holding no wanted frame is never decoded, nor a
group's packets after its last wanted frame: with lerobot's GOP of 2 and a stride of 5, 3 frames in 10. Nothing
after the last wanted frame is decoded.

The frames come back in display order, each placed by its time stamp. Where that placement is not sound — a
packet or frame without a time stamp or off the frame grid, two on one frame slot, a wanted frame the decoder
never returns — `SparseGap` is raised and the caller decodes the span whole instead, which is always right.
"""

from __future__ import annotations

from bisect import bisect_left
from collections.abc import Iterator, Sequence

import av
import av.container
import av.video.frame
import av.video.stream

from openral_data.errors import SparseGap

REORDER = 16  # frames a decoder may hold back (H.264 allows 16 reference frames): past the span by more, stop


def sparse_frames(
    container: av.container.InputContainer, stream: av.video.stream.VideoStream, start: float, n: int, fps: int,
    wanted: int | Sequence[int],
) -> Iterator[av.video.frame.VideoFrame]:  # fmt: skip
    """Frames `wanted` (a stride: frames 0, stride, 2*stride, …; or the indices, ascending, each once) of the `n`
    frames at `fps` from `start` seconds, in order; raises `SparseGap` where placing them by time stamp is not
    sound or the stream ends (or breaks off) before the last of them: the whole decode then says which."""
    tb = stream.time_base
    assert tb is not None
    slots = _Slots(float(tb), start, fps, range(0, n, wanted) if isinstance(wanted, int) else wanted)
    decoder = stream.codec_context
    held: list[av.Packet] = []  # packets not sent yet, from the keyframe before the last one (see above)
    cut, key = 0, 0  # held[cut] is the last keyframe; its slot
    last = -1
    for packet in container.demux(stream):
        if packet.size == 0:  # the demuxer's end marker
            continue
        i = slots.of(packet.pts)
        last = max(last, i)
        if cut and i > key:  # shown after the last keyframe: the packets before it are needed no more
            held, cut = held[cut:], 0
        if packet.is_keyframe:
            cut, key = len(held), i
        held.append(packet)
        if slots.wanted(i):
            # from the last keyframe on, unless a wanted frame shown before it (a leading one) may still come
            send = held[cut:] if i >= key and not slots.unsent_before(key) else held
            for p in send:
                slots.sent(p.pts)
                for frame in decoder.decode(p):
                    slots.keep(frame)
            held, cut = [], 0
            yield from slots.ready()
            if slots.done():
                return
        elif i >= slots.end + REORDER:  # past the last wanted frame by more than a decoder holds back
            break
    for frame in decoder.decode(None):  # what the decoder still holds back
        slots.keep(frame)
    yield from slots.ready()
    if not slots.done():
        ends = "the stream ends before the span"
        raise SparseGap(f"frame {slots.next} never decoded" if last >= slots.end - 1 else ends)


class _Slots:
    """Frame slots from time stamps, and the wanted frames decoded so far, handed on strictly in order."""

    def __init__(self, tb: float, start: float, fps: int, wanted: Sequence[int]) -> None:
        self.tb, self.start, self.fps, self.want = tb, start, fps, wanted
        self.set = wanted if isinstance(wanted, range) else frozenset(wanted)
        self.end = wanted[-1] + 1 if len(wanted) else 0  # past the last wanted slot
        self.kept: dict[int, av.video.frame.VideoFrame] = {}
        self.k = 0  # the next wanted slot to hand on is want[k]
        self.gone: set[int] = set()  # wanted slots from `next` on whose packets the decoder has had

    @property
    def next(self) -> int:
        return self.want[self.k] if self.k < len(self.want) else self.end

    def of(self, pts: int | None) -> int:
        if pts is None:
            raise SparseGap("a packet or frame without a time stamp")
        exact = (pts * self.tb - self.start) * self.fps
        if abs(exact - round(exact)) > 0.25:  # off the frame grid: only counting frames places them
            raise SparseGap(f"time stamp {pts} is off the {self.fps} fps grid")
        return round(exact)

    def wanted(self, i: int) -> bool:
        return i >= self.next and i in self.set

    def sent(self, pts: int | None) -> None:
        i = self.of(pts)
        if self.wanted(i):
            self.gone.add(i)

    def unsent_before(self, key: int) -> bool:
        """Whether a wanted slot before `key` (an open GOP's leading frame, shown before its keyframe) may still
        arrive: its packet not sent yet."""
        stop = bisect_left(self.want, key, lo=self.k)
        return any(self.want[j] not in self.gone for j in range(self.k, stop))

    def keep(self, frame: av.video.frame.VideoFrame) -> None:
        i = self.of(frame.pts)
        if (0 <= i < self.next and i in self.set) or i in self.kept:
            raise SparseGap(f"two frames on slot {i}")  # each packet is decoded once: a slot is decoded once
        if not self.wanted(i):
            return
        self.kept[i] = frame

    def ready(self) -> Iterator[av.video.frame.VideoFrame]:
        while self.next in self.kept:
            yield self.kept.pop(self.next)
            self.gone.discard(self.next)
            self.k += 1

    def done(self) -> bool:
        return self.k >= len(self.want)
