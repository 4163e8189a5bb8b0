"""Cut one episode out of a v3 mp4 that holds many, without re-encoding (a packet-level remux in memory).

v3 writers (ours and lerobot's) encode each episode on its own and join the files, so an episode's first
packet is a keyframe and its packets form a stream that decodes on its own. The clip starts at time 0, so
its frame k is at k / fps. When the episode does not start on a keyframe the whole file is used instead.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass
from fractions import Fraction
from pathlib import Path

import av

from openral_data.errors import DatasetError
from openral_data.paths import regular_file


@dataclass(frozen=True)
class Clip:
    data: bytes | None  # None: use the whole file at `path`
    path: Path
    start: float  # seconds of the episode's first frame inside `data` (0.0) or inside the whole file
    frames: int  # packets that fall inside the episode


def episode_clip(path: Path, from_ts: float, to_ts: float, fps: int) -> Clip:
    """The packets of the episode in [from_ts, to_ts) of the mp4 at `path`; a missing, empty, truncated or
    garbage file raises a `DatasetError` naming it."""
    try:
        return _clip(path, from_ts, to_ts, fps)
    except (av.error.FFmpegError, OSError) as exc:
        reason = getattr(exc, "strerror", None) or type(exc).__name__
        raise DatasetError(f"{path}: cannot read video: {reason}", code="dataset.invalid") from None


def _clip(path: Path, from_ts: float, to_ts: float, fps: int) -> Clip:
    half = Fraction(1, 2 * fps)
    lo = Fraction(from_ts).limit_denominator(1_000_000) - half
    hi = Fraction(to_ts).limit_denominator(1_000_000) - half
    src = av.open(str(regular_file(path)))  # a FIFO would block PyAV for ever
    try:
        if not src.streams.video:
            raise DatasetError(f"{path}: holds no video stream", code="dataset.invalid")
        stream = src.streams.video[0]
        tb = stream.time_base
        if tb is None:
            return Clip(None, path, from_ts, 0)
        if lo > 0:  # start at the keyframe at or before the episode instead of reading the file from its start
            src.seek(max(0, math.floor(lo / tb)), stream=stream, backward=True, any_frame=False)
        packets = []
        for p in src.demux(stream):
            if p.dts is not None and p.dts * tb >= hi:
                break  # decode order: every later packet shows at or after `hi` too
            if p.pts is not None and p.size and lo <= p.pts * tb < hi:
                packets.append((p, p.pts))
        if not packets or not packets[0][0].is_keyframe:
            return Clip(None, path, from_ts, len(packets))
        shift = min(pts for _, pts in packets)
        buf = io.BytesIO()
        with av.open(buf, "w", format="mp4") as dst:
            # opaque: remux only, no codec context (PyAV has no AV1 encoder matching the libdav1d decoder)
            out = dst.add_stream_from_template(stream, opaque=True)
            for p, pts in packets:
                dts = p.dts
                p.pts = pts - shift
                p.dts = None if dts is None else dts - shift  # may start below 0 (B-frame delay), as in the source
                p.stream = out
                dst.mux(p)
        return Clip(buf.getvalue(), path, 0.0, len(packets))
    finally:
        src.close()
