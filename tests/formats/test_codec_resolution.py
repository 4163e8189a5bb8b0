"""Which codec a run encodes with, for every way a user can name it: the `--vcodec`/`--codec` flag, the `codec=`
shorthand of the options objects, `video=VideoSettings(codec=...)`, and a pipeline's `codec:`/`vcodec:` keys.
The rule (one place, `VideoSettings.given`): the shorthand applies when the settings' codec is the default (av1),
else the settings' codec wins; a pipeline's two keys are one setting. The table is the behaviour before the
codec was resolved in one place, pinned for every combination."""

from __future__ import annotations

from typing import Any

import pytest

from openral_data.cli.encoder_flags import video_settings
from openral_data.edit.videos import settings_for
from openral_data.formats.lerobot_v3.encoder import CODECS, VideoSettings
from openral_data.pipeline.schema import RecordStep
from openral_data.record.hal import HalRecordOptions
from openral_data.record.options import RecordOptions

GIVEN = (None, *CODECS)  # None: not given (the default)


def _expected(shorthand: str | None, settings: str | None) -> str:
    """Today's rule, written out: the settings' codec unless it is av1 (the default), then the shorthand's."""
    if settings is not None and settings != "av1":
        return settings
    return shorthand or "av1"


def _video(settings: str | None) -> dict[str, Any]:
    return {} if settings is None else {"video": VideoSettings(codec=settings)}  # type: ignore[arg-type]


def _shorthand(shorthand: str | None) -> dict[str, Any]:
    return {} if shorthand is None else {"codec": shorthand}


@pytest.mark.parametrize("settings", GIVEN)
@pytest.mark.parametrize("shorthand", GIVEN)
def test_options_objects_resolve_the_codec_alike(shorthand: str | None, settings: str | None) -> None:
    want = _expected(shorthand, settings)
    rec = RecordOptions(rskill="zero-mock", **_shorthand(shorthand), **_video(settings))
    assert (rec.codec, rec.video.codec) == (want, want)
    hal = HalRecordOptions(robot="so100", rskill="zero-mock", **_shorthand(shorthand), **_video(settings))
    assert (hal.codec, hal.video.codec) == (want, want)
    edit = settings_for(shorthand or "av1", VideoSettings(codec=settings) if settings else None)  # type: ignore[arg-type]
    assert edit.codec == want
    assert VideoSettings.given(shorthand, **_video(settings)).codec == want


@pytest.mark.parametrize("flag", GIVEN)
def test_the_flag_names_the_codec(flag: str | None) -> None:
    video = video_settings(flag or "av1", None, None, None, None, None)  # typer hands the default when not given
    assert video.codec == (flag or "av1")
    assert video.encoder == {"av1": "libsvtav1", "h264": "libx264", "hevc": "libx265", "auto": "libsvtav1"}[video.codec]


@pytest.mark.parametrize("vcodec", GIVEN)
@pytest.mark.parametrize("codec", GIVEN)
def test_a_pipeline_step_takes_either_key(codec: str | None, vcodec: str | None) -> None:
    keys = {"codec": codec, "vcodec": vcodec}
    step: dict[str, Any] = {"scenes": ["s"], "rskills": ["r"], "seeds": {"count": 1}}
    step |= {k: v for k, v in keys.items() if v is not None}
    if codec is not None and vcodec is not None and codec != vcodec:
        with pytest.raises(ValueError, match=f"codec {codec} and vcodec {vcodec} differ"):
            RecordStep.model_validate(step)
        return
    assert RecordStep.model_validate(step).video_settings().codec == (vcodec or codec or "av1")


def test_a_bad_codec_is_one_line_naming_the_flag() -> None:
    with pytest.raises(Exception, match=r"^--vcodec: 'vp9' is not one of av1, h264, hevc, auto$"):
        VideoSettings.given("vp9")
    with pytest.raises(Exception, match=r"^--vcodec: 'vp9' is not one of av1, h264, hevc, auto$"):
        RecordOptions(rskill="zero-mock", codec="vp9")  # type: ignore[arg-type]
