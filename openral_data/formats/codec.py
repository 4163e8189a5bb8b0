"""The video codecs our writers encode (`Codec`) and `--codec` text checked into one: no PyAV or numpy here, so
the command line can name the type without loading the encoder."""

from __future__ import annotations

from typing import Literal, get_args

from openral_data.errors import UsageError

Codec = Literal["av1", "h264"]
CODECS: tuple[Codec, ...] = get_args(Codec)


def parse_codec(name: str) -> Codec:
    """`--codec` (or any untyped text) -> a `Codec`; below the edge the value is never checked again."""
    for codec in CODECS:
        if name == codec:
            return codec
    raise UsageError(f"--codec: {name!r} is not one of {', '.join(CODECS)}")
