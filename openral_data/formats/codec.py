"""The video codecs our writers encode (`Codec`: av1, h264, hevc, or `auto`, the hardware probe) and `--vcodec`
text checked into one: no PyAV or numpy here, so the command line can name the type without loading the encoder
(formats/lerobot_v3/encoder.py re-exports both)."""

from __future__ import annotations

from typing import Literal, get_args

from openral_data.errors import UsageError

Codec = Literal["av1", "h264", "hevc", "auto"]
CODECS: tuple[Codec, ...] = get_args(Codec)


def parse_codec(name: str) -> Codec:
    """`--vcodec` (or any untyped text) -> a `Codec`; below the edge the value is never checked again."""
    for codec in CODECS:
        if name == codec:
            return codec
    raise UsageError(f"--vcodec: {name!r} is not one of {', '.join(CODECS)}")
