"""Encoder settings as lerobot 0.6.1 names them (`VideoSettings`: vcodec, crf, g, preset, pix_fmt, threads):
each one lands in the video feature's `info` exactly as lerobot's own `get_video_info` writes it for the same
file and config, lerobot rebuilds and accepts that config, and lerobot loads every frame as PyAV decodes it
(h264, hevc, av1; crf, gop, pix_fmt and preset variants, yuv444p where the codec has it). `auto` probes the
hardware encoders once and falls back to software with one log line; a bad combination is refused up front."""

from __future__ import annotations

import json
import logging
import os
from pathlib import Path
from typing import Any

import av
import numpy as np
import pytest

from openral_data.errors import UsageError
from openral_data.formats.lerobot_v3 import encoder
from openral_data.formats.lerobot_v3.encoder import VideoSettings, encoder_threads
from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from tests.support.lerobot_written import VIDEO_CAMERA, loaded_episodes
from tests.support.scenes import mock_scene, write_yaml

LENGTHS = (5, 7)  # two episodes (the second starts mid-file: pts shifted by the first's frames)


def _record(tmp_path: Path, video: VideoSettings) -> Path:
    scene = write_yaml(
        tmp_path / "s.yaml",
        mock_scene(cameras=[("cam", 48, 32)], success_after=list(LENGTHS), n_episodes=len(LENGTHS)),
    )
    out = tmp_path / "ds"
    record(RecordOptions(scene=str(scene), rskill="zero-mock", out=out, video=video))
    return out


def _info(root: Path) -> dict[str, Any]:
    return dict(json.loads((root / "meta/info.json").read_text())["features"][VIDEO_CAMERA]["info"])


def _decoded(root: Path) -> list[np.ndarray]:
    """Every frame of the camera's video files, in file order, as PyAV decodes them (HWC uint8)."""
    frames: list[np.ndarray] = []
    for path in sorted((root / "videos" / VIDEO_CAMERA).rglob("*.mp4")):
        with av.open(str(path)) as container:
            frames += [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]
    return frames


VARIANTS = [
    pytest.param(VideoSettings(codec="h264", crf=18, g=5, pix_fmt="yuv444p", preset="veryfast"), id="h264-444"),
    pytest.param(VideoSettings(codec="hevc"), id="hevc-default"),
    pytest.param(VideoSettings(codec="hevc", crf=24.5, g=3, pix_fmt="yuv444p", preset="ultrafast"), id="hevc-444"),
    pytest.param(VideoSettings(codec="av1", crf=40, g=4, preset=10, threads=1), id="av1-crf-gop"),
]


@pytest.mark.slow  # a recording and lerobot's loader per variant
@pytest.mark.parametrize("video", VARIANTS)
def test_settings_round_trip_into_info_and_load_frame_exact(
    project: Path, tmp_path: Path, video: VideoSettings
) -> None:
    from lerobot.configs.video import RGBEncoderConfig
    from lerobot.datasets.video_utils import get_video_info

    root = _record(tmp_path, video)
    info = _info(root)
    resolved = video.resolve()  # `auto`: the encoder it picks here
    family = {"libsvtav1": "av1", "libx264": "h264", "libx265": "hevc"}.get(resolved.encoder, info["video.codec"])
    assert (info["video.codec"], info["video.pix_fmt"], info["video.g"], info["video.crf"]) == (
        family,
        video.pix_fmt,
        video.g,
        video.crf,
    )
    assert info["video.preset"] == (12 if video.preset is None and resolved.encoder == "libsvtav1" else video.preset)
    # lerobot rebuilds the config from our info (and validates it against FFmpeg), and its own get_video_info
    # for our file and that config is our info key for key, value for value, type for type
    config = RGBEncoderConfig.from_video_info(info)
    files = sorted((root / "videos" / VIDEO_CAMERA).rglob("*.mp4"))
    theirs = get_video_info(files[0], config)
    assert theirs == info
    assert {k: type(v) for k, v in theirs.items()} == {k: type(v) for k, v in info.items()}
    # every frame lerobot loads is the frame PyAV decodes at that place in the file: none lost, none shifted
    loaded = [f["cam"] for episode in loaded_episodes(root) for f in episode]
    decoded = _decoded(root)
    assert [len(e) for e in loaded_episodes(root)] == list(LENGTHS)
    assert len(loaded) == len(decoded) == sum(LENGTHS)
    for got, want in zip(loaded, decoded, strict=True):
        assert np.array_equal(np.round(got.transpose(1, 2, 0) * 255).astype(np.uint8), want)


def test_openral_json_records_the_settings(project: Path, tmp_path: Path) -> None:
    root = _record(tmp_path, VideoSettings(codec="hevc", crf=20, g=4, pix_fmt="yuv444p", preset="fast"))
    config = json.loads((root / "meta/openral.json").read_text())["config"]
    assert {k: config[k] for k in ("codec", "crf", "g", "pix_fmt", "preset")} == {
        "codec": "hevc",
        "crf": 20,
        "g": 4,
        "pix_fmt": "yuv444p",
        "preset": "fast",
    }
    assert "encoder" not in config  # software: the codec names it (a hardware encoder is named, `auto`)


@pytest.mark.parametrize(
    ("video", "message"),
    [
        (VideoSettings(codec="av1", crf=64), "--crf: 64 is out of range for av1 (0..63)"),
        (VideoSettings(codec="h264", crf=52), "--crf: 52 is out of range for h264 (0..51)"),
        (VideoSettings(codec="av1", crf=30.5), "--crf: 30.5: av1 takes a whole number"),
        (VideoSettings(codec="av1", pix_fmt="yuv444p"), "--pix-fmt: 'yuv444p': libsvtav1 encodes yuv420p"),
        (VideoSettings(codec="h264", pix_fmt="rgb48"), "--pix-fmt: 'rgb48': libx264 encodes yuv420p"),
        (VideoSettings(codec="h264", preset="turbo"), "--preset: 'turbo': libx264 takes one of ultrafast"),
        (VideoSettings(codec="av1", preset=14), "--preset: 14: av1 (SVT-AV1) takes -1..13"),
        (VideoSettings(g=0), "--gop: 0 must be a positive integer"),
        (VideoSettings(threads=-1), "--encoder-threads: -1 must be >= 0 (0: the encoder's own default)"),
    ],
)
def test_a_bad_combination_is_one_usage_error(video: VideoSettings, message: str) -> None:
    with pytest.raises(UsageError) as err:
        video.resolve()
    assert str(err.value).startswith(message) and "\n" not in str(err.value)


def test_a_codec_this_ffmpeg_lacks_is_refused(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(encoder.SOFTWARE, "hevc", "libx265_missing")
    with pytest.raises(UsageError, match=r"^--vcodec: hevc: this FFmpeg has no libx265_missing encoder$"):
        VideoSettings(codec="hevc").resolve()


def _auto(monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture, candidates: tuple[str, ...]) -> str:
    monkeypatch.setattr(encoder, "HARDWARE", candidates)
    encoder.auto_encoder.cache_clear()
    try:
        with caplog.at_level(logging.INFO, logger="openral_data"):
            chosen = VideoSettings(codec="auto").resolve()
            again = VideoSettings(codec="auto").resolve()  # probed once per run: no second line
    finally:
        encoder.auto_encoder.cache_clear()
    assert chosen == again
    return chosen.encoder


def test_auto_falls_back_to_software_with_one_line(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """This machine: NVENC is compiled into PyAV's FFmpeg but does not open (no driver); VAAPI/QSV are absent."""
    assert _auto(monkeypatch, caplog, encoder.HARDWARE) == "libsvtav1"
    lines = [r.getMessage() for r in caplog.records if r.name == encoder.log.name]
    assert len(lines) == 1 and lines[0].startswith("vcodec auto: no hardware encoder opens here")
    assert lines[0].endswith("using software libsvtav1")


def test_auto_with_a_missing_hardware_encoder_falls_back(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """A name this FFmpeg lacks and one that fails to open: both skipped, the fallback named once."""
    monkeypatch.setattr(
        encoder, "opens", lambda name, pix_fmt: False if name == "h264_nvenc" else encoder.available(name)
    )
    assert _auto(monkeypatch, caplog, ("h264_gone_nvenc", "h264_nvenc")) == "libsvtav1"
    lines = [r.getMessage() for r in caplog.records if r.name == encoder.log.name]
    assert lines == [
        "vcodec auto: no hardware encoder opens here (h264_nvenc offered but failed); using software libsvtav1"
    ]


def test_auto_takes_the_first_encoder_that_opens(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """The GPU path's choice, with a software encoder standing in for a hardware one that opens."""
    monkeypatch.setattr(encoder, "opens", lambda name, pix_fmt: name == "libx264")
    assert _auto(monkeypatch, caplog, ("h264_gone_nvenc", "libx264")) == "libx264"
    settings = VideoSettings(codec="auto", encoder_name="h264_nvenc")
    assert settings.hardware and settings.feature_info(32, 48, 10)["video.codec"] == "h264"
    assert settings.options() == {"g": "2", "rc": "constqp", "qp": "30"}  # lerobot's NVENC mapping of crf


def test_thread_budget_divides_the_cores(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: set(range(16)), raising=False)
    assert encoder_threads(VideoSettings(), 4) == 4
    assert encoder_threads(VideoSettings(), 32) == 1
    assert encoder_threads(VideoSettings(threads=3), 4) == 3
    assert "lp=" not in VideoSettings(threads=0).options(encoder_threads(VideoSettings(threads=0), 4))["svtav1-params"]
    assert encoder_threads(VideoSettings(encoder_name="h264_nvenc"), 4) is None
    assert VideoSettings().options(2)["svtav1-params"] == "fast-decode=0:lp=2"
    assert VideoSettings(codec="h264").options(2)["threads"] == "2"


def test_a_hardware_encoder_takes_the_semi_planar_twin(monkeypatch: pytest.MonkeyPatch) -> None:
    """QSV takes nv12, not yuv420p: it is fed nv12 and the info still says yuv420p (what the stream reads as)."""
    monkeypatch.setattr(encoder, "available", lambda name: True)
    monkeypatch.setattr(encoder, "pixel_formats", lambda name: ("nv12", "p010le", "qsv"))
    qsv = VideoSettings(codec="auto", encoder_name="h264_qsv")
    assert (qsv.encoder_pix_fmt, qsv.feature_info(32, 48, 10)["video.pix_fmt"]) == ("nv12", "yuv420p")
    assert VideoSettings(codec="h264").encoder_pix_fmt == "yuv420p"  # software: never swapped


@pytest.mark.skipif(encoder.auto_encoder() == encoder.SOFTWARE["av1"], reason="no hardware encoder opens here")
def test_hardware_encoder_round_trip(project: Path, tmp_path: Path) -> None:
    """On a machine where `--vcodec auto` finds a hardware encoder (NVENC, VAAPI, QSV, VideoToolbox): its output
    loads frame-exact in lerobot and its info is lerobot's (benchmarks/README.md#hardware-encoders runs this)."""
    test_settings_round_trip_into_info_and_load_frame_exact(project, tmp_path, VideoSettings(codec="auto", g=4))
