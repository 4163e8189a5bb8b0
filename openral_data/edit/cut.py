"""Keep some frames of an episode's mp4 clip (`EpisodeData.videos`: frame k at k / fps, from pts 0), for
`episodes trim` and `episodes resample`.

`copy_frames` keeps runs of frames by copying their packets (no re-encoding), which is exact but possible only
when every run starts on a keyframe and ends at the clip's end or right before a keyframe: v3 writers (ours and
lerobot's) encode closed groups of pictures, so such a run decodes on its own. The kept packets are renumbered
frame by frame (output frame j at j / fps), in decode order, as `video.concat_mp4` joins episodes.
`keyframes` says which frames are keyframes (from the packets' flags, nothing decoded); `decoded_frames` is the
decoder side of re-encoding (`recode.CameraEncoders` is the encoder side).

Mixing re-encoded groups of pictures with copied packets in one stream would need the new encoder's codec
headers (SPS/PPS, AV1 sequence header) to match the source's bit for bit; a cut that is not on keyframes
therefore re-encodes the episode's kept frames of that camera only (`edit.subset`), never its neighbours.
"""

from __future__ import annotations

import io
from collections.abc import Iterator, Sequence

import av

from openral_data.edit.recode import Pixels, clip_frames
from openral_data.errors import DatasetError

Run = tuple[int, int]  # frames [start, end) of the source clip


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


def copyable(keep: Sequence[int], key: Sequence[bool]) -> bool:
    """Whether the frames `keep` (ascending) can be cut out of a clip with keyframes `key` by copying packets."""
    n = len(key)
    return all(key[a] and (b == n or key[b]) for a, b in runs(keep))


def copy_frames(mp4: bytes, keep: Sequence[int], where: str) -> bytes:
    """A clip of the frames `keep` (ascending, `copyable`) of `mp4`, packets copied, frame j at j / fps."""
    try:
        return _remux(mp4, runs(keep))
    except (av.error.FFmpegError, IndexError, ValueError) as exc:
        raise DatasetError(f"{where}: cannot cut video: {type(exc).__name__}", code="dataset.invalid") from None


def _remux(mp4: bytes, spans: list[Run]) -> bytes:
    buf = io.BytesIO()
    with av.open(io.BytesIO(mp4), mode="r") as src, av.open(buf, "w", format="mp4") as dst:
        stream = src.streams.video[0]
        packets = [p for p in src.demux(stream) if p.pts is not None and p.size]
        pts = sorted({int(p.pts) for p in packets if p.pts is not None})
        step = pts[1] - pts[0] if len(pts) > 1 else 1  # the clip's frame duration in its time base
        frame_of = {t: k for k, t in enumerate(pts)}
        out = dst.add_stream_from_template(stream, opaque=True)  # remux only (see formats/lerobot_v3/clip.py)
        offset = 0  # output frames before the current run
        for a, b in spans:
            shift = (offset - a) * step
            for p in packets:  # decode order within the run: the run is a closed group of pictures
                assert p.pts is not None
                if a <= frame_of[int(p.pts)] < b:
                    dts = p.dts
                    p.pts += shift
                    p.dts = None if dts is None else dts + shift
                    p.stream = out
                    dst.mux(p)
            offset += b - a
    return buf.getvalue()


def decoded_frames(mp4: bytes, keep: Sequence[int], where: str) -> Iterator[Pixels]:
    """The RGB frames `keep` (ascending, may repeat none) of a clip, decoded, in order."""
    wanted = iter(keep)
    nxt = next(wanted, None)
    for k, frame in enumerate(clip_frames(mp4, where)):
        while nxt == k:
            yield frame
            nxt = next(wanted, None)
        if nxt is None:
            return
