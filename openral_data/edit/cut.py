"""Keep some frames of an episode's mp4 clip (`EpisodeData.videos`: frame k at k / fps, from pts 0), for
`episodes trim` and `episodes resample`.

Runs of frames are kept by copying their packets (no re-encoding), which is exact but possible only when a
run starts on a keyframe and ends at the clip's end or right before a keyframe: v3 writers (ours and
lerobot's) encode closed groups of pictures, so such a run decodes on its own. The kept packets are renumbered
frame by frame (output frame j at j / fps), in decode order, as `video.concat_mp4` joins episodes.
`keyframes` says which frames are keyframes (from the packets' flags, nothing decoded); `decoded_frames` is the
decoder side of re-encoding (`recode.CameraEncoders` is the encoder side).

A cut that is not on keyframes is `plan`ned as segments: the groups of pictures between the run's first and
last keyframes are copied, the frames before the first keyframe and from the last keyframe on (at most one
group of pictures at each cut) are encoded again (`edit.subset` encodes them, with the source's settings),
and `splice` muxes both into one stream. That is only sound when the new encoder's codec headers (SPS/PPS, the
AV1 sequence header: the stream's extradata) are the source's byte for byte and the frame duration is a whole
number of time-base ticks; `splice` returns None otherwise, and `edit.subset` checks every copied frame of a
spliced clip decodes to exactly the source's pixels, falling back to encoding all of the episode's kept frames
of that camera (never its neighbours' bytes) when either fails.
"""

from __future__ import annotations

import io
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from fractions import Fraction

import av

from openral_data.edit.recode import Pixels, clip_frames
from openral_data.errors import DatasetError

Run = tuple[int, int]  # frames [start, end) of the source clip
Segment = tuple[bool, int, int]  # (packets copied, start, end): frames [start, end) of the source clip


def runs(keep: Sequence[int]) -> list[Run]:
    """Ascending frame indices as maximal runs of consecutive frames: [0, 1, 2, 5, 6] -> [(0, 3), (5, 7)]."""
    out: list[Run] = []
    for k in keep:
        if out and out[-1][1] == k:
            out[-1] = (out[-1][0], k + 1)
        else:
            out.append((k, k + 1))
    return out


def keyframes(mp4: bytes, where: str) -> list[bool]:
    """Whether each frame (in presentation order) of a clip is a keyframe, from its packets' flags."""
    try:
        with av.open(io.BytesIO(mp4), mode="r") as container:
            stream = container.streams.video[0]
            flags = sorted((p.pts, p.is_keyframe) for p in container.demux(stream) if p.pts is not None and p.size)
    except (av.error.FFmpegError, IndexError) as exc:
        raise DatasetError(f"{where}: cannot read video: {type(exc).__name__}", code="dataset.invalid") from None
    return [key for _, key in flags]


def decoded_frames(mp4: bytes, keep: Sequence[int], where: str) -> Iterator[Pixels]:
    """The RGB frames `keep` (ascending) of a clip, decoded, in order."""
    wanted = iter(keep)
    nxt = next(wanted, None)
    for k, frame in enumerate(clip_frames(mp4, where)):
        while nxt == k:
            yield frame
            nxt = next(wanted, None)
        if nxt is None:
            return


def plan(keep: Sequence[int], key: Sequence[bool]) -> list[Segment]:
    """The kept frames as segments: per run, the frames before its first keyframe (encoded), whole groups of
    pictures (copied), the frames from its last usable keyframe on (encoded); a run without a whole group of
    pictures is encoded as a whole."""
    n = len(key)
    out: list[Segment] = []
    for a, b in runs(keep):
        first = next((k for k in range(a, b) if key[k]), b)
        end = b if b == n or key[b] else max((k for k in range(first, b) if key[k]), default=first)
        if first >= end:
            out.append((False, a, b))
            continue
        out += [seg for seg in ((False, a, first), (True, first, end), (False, end, b)) if seg[2] > seg[1]]
    return out


def splice(mp4: bytes, segments: Sequence[Segment], encoded: Sequence[bytes], fps: int, where: str) -> bytes | None:
    """One clip of `segments` (`plan`): the copied ones' packets from `mp4`, each other one's from its clip in
    `encoded` (in order), frame j at j / fps; None when the encoded clips' codec headers differ from the source's
    or the timing cannot be expressed (the caller encodes everything instead)."""
    try:
        return _rewrite(mp4, fps, lambda clip: _spliced(clip, segments, list(encoded)))
    except (av.error.FFmpegError, IndexError, ValueError):
        return None  # e.g. decode timestamps that would not increase: not spliceable


def select(mp4: bytes, keep: Sequence[int], fps: int, where: str) -> bytes | None:
    """A clip of the frames `keep` of `mp4`, every one a keyframe (`keyframes`), shown at j / `fps`: their
    packets copied (a keyframe decodes on its own), decode times lagging as the source's do; None when the
    source's time base cannot express 1 / `fps`."""
    try:
        return _rewrite(mp4, fps, lambda clip: _selected(clip, keep))
    except (av.error.FFmpegError, IndexError, ValueError) as exc:
        raise DatasetError(f"{where}: cannot cut video: {type(exc).__name__}", code="dataset.invalid") from None


@dataclass(frozen=True)
class _Clip:
    stream: av.VideoStream
    tb: Fraction
    step: int  # an output frame's duration, in ticks of `tb`
    packets: list[av.Packet]  # in decode order, each with pts and dts
    delay: int  # ticks the first frame decodes before it shows (B-frames): the clip shows frame 0 at pts 0


def _rewrite(mp4: bytes, fps: int, choose: Callable[[_Clip], list[av.Packet] | None]) -> bytes | None:
    """A clip of the packets `choose` takes from `mp4` (re-stamped, in decode order), muxed without decoding;
    None when `choose` refuses or `mp4`'s time base cannot express 1 / `fps`."""
    buf = io.BytesIO()
    with av.open(io.BytesIO(mp4), mode="r") as src:
        stream = src.streams.video[0]
        tb = stream.time_base
        if tb is None or (1 / (tb * fps)).denominator != 1:
            return None
        packets = [p for p in src.demux(stream) if p.pts is not None and p.dts is not None and p.size]
        delay = max(0, -min(int(p.dts or 0) for p in packets))
        chosen = choose(_Clip(stream, tb, int(1 / (tb * fps)), packets, delay))
        if chosen is None:
            return None
        with av.open(buf, "w", format="mp4") as dst:
            out = dst.add_stream_from_template(stream, opaque=True)  # remux only (see formats/lerobot_v3/clip.py)
            for p in chosen:
                p.stream = out
                dst.mux(p)
    return buf.getvalue()


def _spliced(clip: _Clip, segments: Sequence[Segment], encoded: list[bytes]) -> list[av.Packet] | None:
    starts = sorted({int(p.pts or 0) for p in clip.packets})
    frame_of = {t: k for k, t in enumerate(starts)}
    out: list[av.Packet] = []
    offset = 0  # output frames before the segment
    fresh = iter(encoded)
    for copied, a, b in segments:
        if copied:  # decode order within the segment: it is a closed group of pictures
            shift = (offset - a) * clip.step
            moved = [p for p in clip.packets if a <= frame_of[int(p.pts or 0)] < b]
            for p in moved:
                p.pts, p.dts = int(p.pts or 0) + shift, int(p.dts or 0) + shift
        else:
            placed = _encoded_packets(next(fresh), clip, offset * clip.step)
            if placed is None:
                return None
            moved = placed
        out += moved
        offset += b - a
    return out


def _encoded_packets(data: bytes, clip: _Clip, start: int) -> list[av.Packet] | None:
    """An encoded segment's packets, re-stamped in `clip`'s time base from `start` on, decoding as much ahead of
    showing as `clip`'s own, so that decode times keep rising across segments and across the episodes
    `video.concat_mp4` joins after this one. None when its codec headers are not `clip`'s or its timing cannot
    be made `clip`'s."""
    with av.open(io.BytesIO(data), mode="r") as container:
        stream = container.streams.video[0]
        if stream.codec_context.extradata != clip.stream.codec_context.extradata or stream.time_base is None:
            return None
        scale = stream.time_base / clip.tb
        packets = [p for p in container.demux(stream) if p.pts is not None and p.dts is not None and p.size]
    times = [(p.pts * scale, p.dts * scale) for p in packets if p.pts is not None and p.dts is not None]
    # frame times (k / fps) are whole ticks of both time bases, whatever their ratio
    if not times or any(t.denominator != 1 for pair in times for t in pair):
        return None
    lag = -min(int(d) for _, d in times) - clip.delay  # how much later than the source's this clip decodes
    for p, (pts, dts) in zip(packets, times, strict=True):
        p.pts, p.dts = start + int(pts), start + int(dts) + lag
        if p.dts > p.pts:
            return None
        p.time_base = clip.tb
    return packets


def _selected(clip: _Clip, keep: Sequence[int]) -> list[av.Packet]:
    shown = sorted(clip.packets, key=lambda p: int(p.pts or 0))
    source_step = int(shown[1].pts or 0) - int(shown[0].pts or 0) if len(shown) > 1 else clip.step
    lag = -(clip.delay // -source_step)  # the source's decode lag, in whole frames
    out = []
    for j, k in enumerate(keep):
        p = shown[k]
        p.pts, p.dts = j * clip.step, (j - lag) * clip.step
        out.append(p)
    return out
