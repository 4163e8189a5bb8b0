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
from collections.abc import Iterator, Sequence
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
        return _splice(mp4, segments, list(encoded), fps)
    except (av.error.FFmpegError, IndexError, ValueError):
        return None  # e.g. decode timestamps that would not increase: not spliceable


def _splice(mp4: bytes, segments: Sequence[Segment], encoded: list[bytes], fps: int) -> bytes | None:
    buf = io.BytesIO()
    with av.open(io.BytesIO(mp4), mode="r") as src, av.open(buf, "w", format="mp4") as dst:
        stream = src.streams.video[0]
        tb = stream.time_base
        if tb is None or (1 / (tb * fps)).denominator != 1:
            return None
        step = int(1 / (tb * fps))
        packets = [p for p in src.demux(stream) if p.pts is not None and p.dts is not None and p.size]
        starts = sorted({int(p.pts) for p in packets if p.pts is not None})
        delay = -min(int(p.dts) for p in packets if p.dts is not None)  # the clip shows frame 0 at pts 0
        frame_of = {t: k for k, t in enumerate(starts)}
        out = dst.add_stream_from_template(stream, opaque=True)
        offset = 0
        clips = iter(encoded)
        for copied, a, b in segments:
            if copied:
                moved = [
                    (p, (offset - a) * step) for p in packets if p.pts is not None and a <= frame_of[int(p.pts)] < b
                ]
            else:
                fresh = _encoded_packets(next(clips), stream.codec_context.extradata, tb, offset * step, delay)
                if fresh is None:
                    return None
                moved = fresh
            for p, shift in moved:
                assert p.pts is not None
                dts = p.dts
                p.pts += shift
                p.dts = None if dts is None else dts + shift
                p.stream = out
                dst.mux(p)
            offset += b - a
    return buf.getvalue()


def _encoded_packets(
    clip: bytes, extradata: bytes | None, tb: Fraction, start: int, delay: int
) -> list[tuple[av.Packet, int]] | None:
    """An encoded segment's packets, their timestamps rescaled to `tb` and the shift placing them at `start`;
    their decode timestamps lag their presentation by the source's `delay` (ticks), so that decode times keep
    rising across segments and across the episodes `video.concat_mp4` joins after this one. None when its codec
    headers are not `extradata` or its timing cannot be made the source's."""
    with av.open(io.BytesIO(clip), mode="r") as container:
        stream = container.streams.video[0]
        if stream.codec_context.extradata != extradata or stream.time_base is None:
            return None
        scale = stream.time_base / tb
        packets = [p for p in container.demux(stream) if p.pts is not None and p.dts is not None and p.size]
    times = [(p.pts * scale, p.dts * scale) for p in packets if p.pts is not None and p.dts is not None]
    # frame times (k / fps) are whole ticks of both time bases, whatever their ratio
    if not times or any(t.denominator != 1 for pair in times for t in pair):
        return None
    lag = -min(int(d) for _, d in times) - delay  # how much later than the source's this clip decodes
    moved = []
    for p, (pts, dts) in zip(packets, times, strict=True):
        p.pts, p.dts = int(pts), int(dts) + lag
        if p.dts > p.pts:
            return None
        p.time_base = tb
        moved.append((p, start))
    return moved
