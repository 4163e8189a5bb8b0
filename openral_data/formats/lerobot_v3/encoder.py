"""Encoder settings as lerobot 0.6.1 names them (`VideoSettings`: vcodec, crf, g, preset, pix_fmt, encoder
threads), checked against this FFmpeg before episode 0, and `--vcodec auto`'s hardware probe.

lerobot keeps them in `VideoEncoderConfig` and writes them into each video feature's `info` (`get_video_info`:
`video.codec` is the stream's canonical codec name, `video.g`/`crf`/`preset`/`fast_decode`/`video_backend`/
`extra_options` the config's); `feature_info` writes the same keys with the same types. The encoder threads are
not part of the info (lerobot passes them per run, not per feature); neither is the FFmpeg encoder that ran
(`h264_nvenc`, `libx264`): `WriterConfig.settings_json` records that in meta/openral.json.

`auto` (`resolve`) tries, once per process, the hardware encoders PyAV's FFmpeg offers, in lerobot's order
of preference (H.264 first: every decoder has it), opening a tiny context and encoding one frame with each (an
NVENC build on a machine without an NVIDIA driver offers `h264_nvenc` but cannot open it). The first that works
is used; with none, one log line says so and the software AV1 encoder runs, as lerobot does.
"""

from __future__ import annotations

import functools
import logging
import os
from dataclasses import dataclass, replace
from fractions import Fraction
from typing import Any

import av

from openral_data.errors import UsageError
from openral_data.formats.codec import CODECS, Codec, parse_codec

__all__ = [  # the codec names are formats/codec.py's (no PyAV there), re-exported here with the settings
    "AUTO_FALLBACK",
    "CODECS",
    "CRF_RANGE",
    "HARDWARE",
    "SEMI_PLANAR",
    "SOFTWARE",
    "SVT_AV1_PRESET",
    "SVT_PRESETS",
    "X26X_PRESETS",
    "X265_NARROW",
    "Codec",
    "VideoSettings",
    "auto_encoder",
    "available",
    "encoder_threads",
    "family",
    "opens",
    "parse_codec",
    "pixel_formats",
    "preset_value",
]

log = logging.getLogger(__name__)

SOFTWARE: dict[str, str] = {"av1": "libsvtav1", "h264": "libx264", "hevc": "libx265"}
# `auto`'s candidates, first preferred (lerobot's order: H.264, then HEVC; AV1 encoders last)
HARDWARE: tuple[str, ...] = (
    "h264_videotoolbox",
    "hevc_videotoolbox",
    "h264_nvenc",
    "hevc_nvenc",
    "h264_vaapi",
    "h264_qsv",
    "hevc_vaapi",
    "hevc_qsv",
    "av1_nvenc",
    "av1_vaapi",
    "av1_qsv",
)
AUTO_FALLBACK = "av1"  # lerobot's: libsvtav1
SVT_AV1_PRESET = 12  # lerobot's LIBSVTAV1_DEFAULT_PRESET
CRF_RANGE: dict[str, tuple[int, int]] = {"av1": (0, 63), "h264": (0, 51), "hevc": (0, 51)}
X26X_PRESETS = ("ultrafast", "superfast", "veryfast", "faster", "fast", "medium", "slow", "slower", "veryslow")
SVT_PRESETS = range(-1, 14)
SEMI_PLANAR = {"yuv420p": "nv12", "yuv420p10le": "p010le"}  # what hardware encoders take for the planar ones
X265_NARROW = 64  # below this width, x265's cu-tree is turned off (`options`)


def family(encoder: str) -> str:
    """The codec an FFmpeg encoder writes (`h264_nvenc` -> h264), as the stream names it (`video.codec`)."""
    named = {name: codec for codec, name in SOFTWARE.items()}.get(encoder)
    if named is not None:
        return named
    if encoder in HARDWARE:  # h264_qsv, hevc_nvenc, av1_vaapi, ...: named after what they write
        return encoder.split("_", maxsplit=1)[0]
    return str(av.codec.Codec(encoder, "w").canonical_name)


@dataclass(frozen=True)
class VideoSettings:
    """lerobot 0.6.1's encoder defaults: yuv420p, g=2, crf=30; SVT-AV1 preset 12, fast-decode 0. `threads`
    is the thread budget of one camera's encoder (SVT-AV1 `lp`, x264/x265 `threads`; None: the writer divides
    the machine's cores among its cameras; 0: the encoder's own default, every core for each).
    `encoder_name` is the FFmpeg encoder `resolve` chose for `auto`."""

    codec: Codec = "av1"
    crf: int | float = 30
    g: int = 2
    preset: int | str | None = None
    pix_fmt: str = "yuv420p"
    threads: int | None = None
    encoder_name: str | None = None

    @property
    def encoder(self) -> str:
        if self.encoder_name is not None:
            return self.encoder_name
        return SOFTWARE[AUTO_FALLBACK if self.codec == "auto" else self.codec]

    @property
    def hardware(self) -> bool:
        return self.encoder not in SOFTWARE.values()

    @property
    def encoder_pix_fmt(self) -> str:
        """The pixel format the encoder is fed: `pix_fmt`, or its semi-planar twin for a hardware encoder that
        takes only that (QSV, some NVENC builds: yuv420p -> nv12, the same 4:2:0 stream, read back as yuv420p)."""
        formats = pixel_formats(self.encoder) if available(self.encoder) else ()
        if self.pix_fmt in formats or not self.hardware:
            return self.pix_fmt
        twin = SEMI_PLANAR.get(self.pix_fmt)
        return twin if twin in formats else self.pix_fmt

    @property
    def effective_preset(self) -> int | str | None:
        if self.encoder == "libsvtav1":
            return SVT_AV1_PRESET if self.preset is None else self.preset
        return self.preset

    def size_problem(self, height: int, width: int) -> str | None:
        """Why frames of this size cannot be encoded, or None. (SVT-AV1 dies with SIGFPE below ~26 px wide.)"""
        if height % 2 or width % 2:
            return f"{width}x{height}: video ({self.pix_fmt}) needs even width and height"
        name = family(self.encoder)
        low = 32 if name == "av1" else 16
        if height < low or width < low:
            return f"{width}x{height}: {name} video needs at least {low}x{low} pixels"
        return None

    def options(self, threads: int | None = None, width: int | None = None) -> dict[str, str]:
        """The encoder's options, as lerobot's `get_codec_options` maps them; `threads` (else `self.threads`)
        is the budget of this encoder, `width` the frames' (x265 needs a workaround for narrow ones)."""
        threads = self.threads if threads is None else threads
        opts = {"g": str(self.g)}
        enc = self.encoder
        preset = self.effective_preset
        if enc in SOFTWARE.values():
            opts["crf"] = str(self.crf)
            if preset is not None:
                opts["preset"] = str(preset)
            if enc == "libsvtav1":
                opts["svtav1-params"] = "fast-decode=0" + (f":lp={threads}" if threads else "")
            elif threads:
                opts["threads"] = str(threads)
            if enc == "libx265":  # its banner silenced, as depth.py does
                # closed GOPs: x265's open GOP decodes a keyframe before the frames shown just ahead of it, so
                # lerobot's decoder (seek to the keyframe before t, decode forward) never sees those frames;
                # x265 4.1 corrupts its heap on frames 33..48 px wide (below ~96 px high) unless cu-tree is off
                narrow = width is not None and width < X265_NARROW
                opts["x265-params"] = "log-level=error:open-gop=0" + (":cutree=0" if narrow else "")
        elif enc.endswith("_nvenc"):
            opts.update({"rc": "constqp", "qp": str(round(self.crf))})
            if preset is not None:
                opts["preset"] = str(preset)
        elif enc.endswith("_vaapi"):
            opts["qp"] = str(round(self.crf))
        elif enc.endswith("_qsv"):
            opts["global_quality"] = str(round(self.crf))
        elif enc.endswith("_videotoolbox"):
            opts["q:v"] = str(max(1, min(100, 100 - round(self.crf) * 2)))
        return opts

    def feature_info(self, height: int, width: int, fps: int) -> dict[str, Any]:
        """The `info` block lerobot writes for a video feature (`get_video_info`), key for key."""
        return {
            "video.height": height,
            "video.width": width,
            "video.codec": family(self.encoder),
            "video.pix_fmt": self.pix_fmt,
            "video.fps": fps,
            "video.channels": 3,
            "has_audio": False,
            "video.g": self.g,
            "video.crf": self.crf,
            "video.preset": self.effective_preset,
            "video.fast_decode": 0,
            "video.video_backend": "pyav",
            "video.extra_options": {},
            "is_depth_map": False,
        }

    @classmethod
    def given(
        cls,
        codec: str | None = None,
        *,
        crf: float | None = None,
        g: int | None = None,
        preset: int | str | None = None,
        pix_fmt: str | None = None,
        threads: int | None = None,
        video: VideoSettings | None = None,
    ) -> VideoSettings:
        """The one place a run's encoder settings are decided: what the user gave (a flag, a pipeline key, an API
        argument; None: not given) over `video` (default: lerobot's), resolved (`auto` probed) and checked.
        `codec` is the shorthand of `video.codec` (`--vcodec`, its alias `--codec`, a pipeline's `codec:` or
        `vcodec:`, `RecordOptions(codec=...)`): it applies while `video.codec` is the default (av1), else
        `video.codec` wins, so `RecordOptions(codec="h264")` and `RecordOptions(video=...)` both work."""
        base = video or cls()
        named = parse_codec(codec) if codec is not None else base.codec
        return replace(
            base,
            codec=named if base.codec == "av1" else base.codec,
            crf=base.crf if crf is None else (int(crf) if crf == int(crf) else crf),
            g=base.g if g is None else g,
            preset=base.preset if preset is None else preset,
            pix_fmt=base.pix_fmt if pix_fmt is None else pix_fmt,
            threads=base.threads if threads is None else threads,
        ).resolve()

    def resolve(self) -> VideoSettings:
        """These settings with a concrete encoder (`auto` probed), checked against this FFmpeg: a bad
        combination is one `UsageError` naming the flag, before anything is encoded."""
        settings = self
        if self.codec == "auto" and self.encoder_name is None:
            settings = replace(self, encoder_name=auto_encoder(self.pix_fmt))
        settings.check()
        return settings

    def check(self) -> None:
        enc = self.encoder
        name = family(enc) if available(enc) else (self.codec if self.codec != "auto" else enc)
        if not available(enc):
            raise UsageError(f"--vcodec: {name}: this FFmpeg has no {enc} encoder")
        if isinstance(self.g, bool) or not isinstance(self.g, int) or self.g < 1:
            raise UsageError(f"--gop: {self.g!r} must be a positive integer")
        lo, hi = CRF_RANGE[name]
        if isinstance(self.crf, bool) or not isinstance(self.crf, int | float) or not lo <= self.crf <= hi:
            raise UsageError(f"--crf: {self.crf!r} is out of range for {name} ({lo}..{hi})")
        if enc == "libsvtav1" and self.crf != int(self.crf):
            raise UsageError(f"--crf: {self.crf!r}: av1 takes a whole number")
        formats = pixel_formats(enc)
        if self.encoder_pix_fmt not in formats:
            raise UsageError(f"--pix-fmt: {self.pix_fmt!r}: {enc} encodes {', '.join(formats)}")
        self._check_preset(enc)
        if self.threads is not None and (isinstance(self.threads, bool) or self.threads < 0):
            raise UsageError(f"--encoder-threads: {self.threads!r} must be >= 0 (0: the encoder's own default)")

    def _check_preset(self, enc: str) -> None:
        preset = self.effective_preset
        if preset is None:
            return
        if enc == "libsvtav1":
            if isinstance(preset, bool) or not isinstance(preset, int) or preset not in SVT_PRESETS:
                raise UsageError(f"--preset: {preset!r}: av1 (SVT-AV1) takes -1..13")
        elif enc in ("libx264", "libx265") and preset not in X26X_PRESETS:
            raise UsageError(f"--preset: {preset!r}: {enc} takes one of {', '.join(X26X_PRESETS)}")


def encoder_threads(settings: VideoSettings, cameras: int) -> int | None:
    """One camera's encoder thread budget: `settings.threads` if given, else this process's cores divided among
    the `cameras` encoding at once (N encoders each spawning a thread per core fight over the same cores);
    None for a hardware encoder (the device does the work)."""
    if settings.threads is not None or settings.hardware:
        return settings.threads
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return max(1, cores // max(1, cameras))


def preset_value(text: str | None) -> int | str | None:
    """`--preset` text: a number for SVT-AV1 (`8`), a name for x264/x265 (`veryfast`)."""
    if text is None:
        return None
    return int(text) if text.lstrip("-").isdigit() else text


@functools.cache
def available(encoder: str) -> bool:
    try:
        return av.codec.Codec(encoder, "w").type == "video"
    except Exception:  # noqa: BLE001 - PyAV raises UnknownCodecError or a plain error for a missing name
        return False


@functools.cache
def pixel_formats(encoder: str) -> tuple[str, ...]:
    return tuple(f.name for f in (av.codec.Codec(encoder, "w").video_formats or ()))


def opens(encoder: str, pix_fmt: str) -> bool:
    """Whether `encoder` opens here and encodes a tiny frame (a driver, a device, a licence: all must be there)."""
    if not available(encoder):
        return False
    try:
        ctx = av.CodecContext.create(encoder, "w")
        assert isinstance(ctx, av.VideoCodecContext)
        ctx.width, ctx.height = 64, 64
        ctx.time_base = Fraction(1, 30)
        ctx.pix_fmt = pix_fmt if pix_fmt in pixel_formats(encoder) else SEMI_PLANAR.get(pix_fmt, pix_fmt)
        ctx.open()
        frame = av.VideoFrame(64, 64, "rgb24").reformat(format=ctx.pix_fmt)
        frame.pts = 0
        ctx.encode(frame)
        ctx.encode(None)
        return True
    except Exception:  # noqa: BLE001 - any failure means: not usable on this machine
        return False


@functools.cache
def auto_encoder(pix_fmt: str = "yuv420p", candidates: tuple[str, ...] | None = None) -> str:
    """`--vcodec auto`: the first hardware encoder that opens here, else the software fallback (one log line).
    Probed once per process (and per pixel format)."""
    tried = HARDWARE if candidates is None else candidates
    for name in tried:
        if opens(name, pix_fmt):
            log.warning("vcodec auto: using hardware encoder %s", name, extra={"encoder": name})
            return name
    fallback = SOFTWARE[AUTO_FALLBACK]
    offered = [n for n in tried if available(n)]
    log.warning(
        "vcodec auto: no hardware encoder opens here (%s); using software %s",
        ", ".join(offered) + " offered but failed" if offered else "none offered",
        fallback,
        extra={"encoder": fallback},
    )
    return fallback
