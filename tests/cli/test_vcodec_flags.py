"""The encoder flags as lerobot names them on `record`, `convert` and `videos reencode|encode-images`
(`--vcodec`, its alias `--codec`, `--crf`, `--gop`, `--preset`, `--pix-fmt`, `--encoder-threads`) and in a
pipeline's record step: what they set lands in each video feature's `info`; a bad combination is one line, exit
2, before anything is written; `--vcodec auto` on this CPU-only machine says in one line that it fell back."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest
import yaml

from openral_data.errors import ConfigError
from openral_data.formats.lerobot_v3 import encoder
from openral_data.pipeline.schema import load_pipeline
from openral_data.pipeline.state import config_hash
from tests.support.inproc import run_inproc
from tests.support.scenes import mock_scene, write_yaml

CAMERA = "observation.images.cam"
SETTINGS = ["--crf", "22", "--gop", "3", "--pix-fmt", "yuv444p", "--preset", "ultrafast", "--encoder-threads", "1"]


def _scene(tmp_path: Path) -> Path:
    return write_yaml(tmp_path / "s.yaml", mock_scene(cameras=[("cam", 64, 48)], success_after=[4, 3], n_episodes=2))


def _info(root: Path) -> dict[str, Any]:
    return dict(json.loads((root / "meta/info.json").read_text())["features"][CAMERA]["info"])


def _picked(info: dict[str, Any]) -> tuple[Any, ...]:
    return tuple(info[k] for k in ("video.codec", "video.crf", "video.g", "video.pix_fmt", "video.preset"))


def _record(tmp_path: Path, out: Path, *flags: str) -> Any:
    return run_inproc("record", "--scene", str(_scene(tmp_path)), "--rskill", "zero-mock", "--out", str(out), *flags)


def test_record_writes_every_setting_into_info(project: Path, tmp_path: Path) -> None:
    res = _record(tmp_path, tmp_path / "ds", "--vcodec", "hevc", *SETTINGS)
    assert res.returncode == 0, res.stderr
    assert _picked(_info(tmp_path / "ds")) == ("hevc", 22, 3, "yuv444p", "ultrafast")
    res = _record(tmp_path, tmp_path / "alias", "--codec", "h264", "--crf", "18.5")  # the old name still works
    assert res.returncode == 0, res.stderr
    assert _picked(_info(tmp_path / "alias")) == ("h264", 18.5, 2, "yuv420p", None)


@pytest.mark.parametrize(
    ("flags", "line"),
    [
        (["--vcodec", "av1", "--crf", "64"], "error: --crf: 64 is out of range for av1 (0..63)"),
        (["--vcodec", "av1", "--pix-fmt", "yuv444p"], "error: --pix-fmt: 'yuv444p': libsvtav1 encodes yuv420p"),
        (["--vcodec", "h264", "--preset", "9"], "error: --preset: 9: libx264 takes one of ultrafast"),
        (["--vcodec", "vp9"], "error: --vcodec: 'vp9' is not one of 'av1', 'h264', 'hevc', 'auto'"),
    ],
)
def test_record_refuses_a_bad_combination_before_writing(
    project: Path, tmp_path: Path, flags: list[str], line: str
) -> None:
    res = _record(tmp_path, tmp_path / "ds", *flags)
    assert res.returncode == 2
    assert line in res.stderr and (res.stderr.count("\n") == 1 or not line.startswith("error:"))
    assert not (tmp_path / "ds").exists()


def test_auto_falls_back_to_software_in_one_line(project: Path, tmp_path: Path) -> None:
    encoder.auto_encoder.cache_clear()  # a run probes once: this test is a run of its own
    try:
        res = _record(tmp_path, tmp_path / "ds", "--vcodec", "auto")
    finally:
        encoder.auto_encoder.cache_clear()
    assert res.returncode == 0, res.stderr
    lines = [line for line in res.stderr.splitlines() if "vcodec auto" in line]
    assert len(lines) == 1 and "no hardware encoder opens here" in lines[0] and "software libsvtav1" in lines[0]
    assert _picked(_info(tmp_path / "ds")) == ("av1", 30, 2, "yuv420p", 12)


@pytest.mark.slow  # a recording, a conversion and two re-encodes
def test_convert_and_videos_take_the_flags(project: Path, tmp_path: Path) -> None:
    rec = tmp_path / "rec"
    assert _record(tmp_path, rec, "--codec", "h264", "--format", "lerobot,mcap").returncode == 0
    res = run_inproc("convert", str(rec / "mcap"), str(tmp_path / "conv"), "--vcodec", "hevc", *SETTINGS)
    assert res.returncode == 0, res.stderr
    assert _picked(_info(tmp_path / "conv")) == ("hevc", 22, 3, "yuv444p", "ultrafast")
    bad = run_inproc("convert", str(rec / "mcap"), str(tmp_path / "bad"), "--vcodec", "hevc", "--crf", "60")
    assert (bad.returncode, bad.stderr) == (2, "error: --crf: 60 is out of range for hevc (0..51)\n")
    assert not (tmp_path / "bad").exists()

    res = run_inproc("videos", "reencode", str(rec), "--vcodec", "h264", *SETTINGS[:6], "--out", str(tmp_path / "re"))
    assert res.returncode == 0, res.stderr
    assert _picked(_info(tmp_path / "re")) == ("h264", 22, 3, "yuv444p", None)
    bad = run_inproc("videos", "reencode", str(rec), "--vcodec", "av1", "--gop", "0", "--out", str(tmp_path / "x"))
    assert (bad.returncode, bad.stderr) == (2, "error: --gop: 0 must be a positive integer\n")
    assert not (tmp_path / "x").exists()
    bad = run_inproc("videos", "encode-images", str(rec), "--pix-fmt", "gray", "--out", str(tmp_path / "y"))
    assert bad.returncode == 2 and bad.stderr.startswith("error: --pix-fmt: 'gray': libsvtav1 encodes")
    assert not (tmp_path / "y").exists()


def _pipeline(tmp_path: Path, **record: Any) -> Path:
    step = {"scenes": ["tabletop_push"], "rskills": ["zero-mock"], "seeds": {"count": 1}, **record}
    spec = {"name": "enc", "steps": [{"id": "rec", "record": step}]}
    path = tmp_path / "p.yaml"
    path.write_text(yaml.safe_dump(spec))
    return path


def test_pipeline_record_step_takes_the_settings(project: Path, tmp_path: Path) -> None:
    step = load_pipeline(_pipeline(tmp_path, vcodec="hevc", crf=20, gop=4, pix_fmt="yuv444p")).steps[0]
    assert step.record is not None
    video = step.record.video_settings()
    assert (video.codec, video.crf, video.g, video.pix_fmt) == ("hevc", 20, 4, "yuv444p")
    plain = load_pipeline(_pipeline(tmp_path, codec="h264")).steps[0]
    assert config_hash(plain) != config_hash(step)
    with pytest.raises(ConfigError, match=r"--crf: 99 is out of range for av1"):
        load_pipeline(_pipeline(tmp_path, crf=99))
    with pytest.raises(ConfigError, match=r"codec h264 and vcodec hevc differ"):
        load_pipeline(_pipeline(tmp_path, codec="h264", vcodec="hevc"))


@pytest.mark.slow  # three recordings into one dataset
def test_resume_keeps_the_recorded_settings(project: Path, tmp_path: Path) -> None:
    out = tmp_path / "ds"
    assert _record(tmp_path, out, "--vcodec", "hevc", "--crf", "20", "--gop", "4", "--n-episodes", "1").returncode == 0
    res = _record(tmp_path, out, "--resume", "--n-episodes", "2")
    assert res.returncode == 0, res.stderr
    assert _picked(_info(out)) == ("hevc", 20, 4, "yuv420p", None)
    assert json.loads((out / "meta/info.json").read_text())["total_episodes"] == 2
    res = _record(tmp_path, out, "--resume", "--n-episodes", "3", "--crf", "25")
    assert res.returncode == 2
    assert "video.crf: the dataset was recorded with 20; --crf 25 differs" in res.stderr
