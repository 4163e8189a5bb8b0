"""The encoder flags `record`, `convert` and `videos reencode|encode-images` share, named as lerobot names them
(`--dataset.rgb_encoder.{vcodec,crf,g,preset,pix_fmt}`, `encoder_threads`), and the `VideoSettings` they make."""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated

import typer

if TYPE_CHECKING:  # the encoder (PyAV, the writer) loads when the flags are turned into settings
    from openral_data.formats.lerobot_v3.encoder import VideoSettings

VCODEC_HELP = "video codec: av1, h264, hevc, or auto (a hardware encoder that opens here, else av1)"
CrfFlag = Annotated[float | None, typer.Option("--crf", help="encoder quality: lower is better (default 30)")]
GopFlag = Annotated[int | None, typer.Option("--gop", help="keyframe interval, frames (lerobot's g; default 2)")]
PresetFlag = Annotated[
    str | None, typer.Option("--preset", help="speed preset: SVT-AV1 -1..13 (default 12), x264/x265 a name")
]
PixFmtFlag = Annotated[
    str | None, typer.Option("--pix-fmt", help="pixel format encoded, e.g. yuv444p (default yuv420p)")
]
ThreadsFlag = Annotated[
    int | None,
    typer.Option(
        "--encoder-threads", help="threads per camera's encoder (default: cores / cameras; 0: the encoder's own)"
    ),
]


def video_settings(
    codec: str, crf: float | None, gop: int | None, preset: str | None, pix_fmt: str | None, threads: int | None
) -> VideoSettings:
    """The flags as one `VideoSettings`, resolved (`auto` probed) and checked: a bad combination is one line."""
    from openral_data.formats.lerobot_v3.encoder import VideoSettings, preset_value

    return VideoSettings.given(codec, crf=crf, g=gop, preset=preset_value(preset), pix_fmt=pix_fmt, threads=threads)
