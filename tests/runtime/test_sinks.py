"""`--format`, `--image-format`, `--mcap-compression`: text becomes a typed value once, at the edge, with one
`error:` line for a bad value; the typed value reaches the MCAP writer unchanged."""

from __future__ import annotations

from pathlib import Path

import pytest

from openral_data.errors import UsageError
from openral_data.formats.lerobot_v3 import WriterConfig
from openral_data.formats.mcap import McapSink, parse_compression, parse_image_format
from openral_data.record.options import RecordOptions
from openral_data.runtime.sinks import make_sinks, parse_formats
from openral_data.types import CameraShape, DatasetSchema

SCHEMA = DatasetSchema(
    fps=10, state_names=("a",), action_names=("x",), cameras={"cam": CameraShape(16, 16)}, robot_type="r"
)


def test_text_becomes_the_typed_value() -> None:
    assert parse_formats(" mcap , lerobot") == ("mcap", "lerobot")
    assert parse_image_format("png") == "png"
    assert parse_compression("lz4") == "lz4"


@pytest.mark.parametrize(
    ("parse", "text", "message"),
    [
        (parse_formats, ",", "--format: choose at least one of lerobot, mcap"),
        (parse_formats, "lerobot,rosbag", "--format: unknown format(s) rosbag (valid: lerobot, mcap)"),
        (parse_formats, "mcap,mcap", "--format: a format is listed twice in mcap,mcap"),
        (parse_image_format, "webp", "--image-format: 'webp' is not one of jpeg, png, raw"),
        (parse_compression, "gzip", "--mcap-compression: 'gzip' is not one of zstd, lz4, none"),
    ],
)
def test_a_bad_value_is_one_line(parse: object, text: str, message: str) -> None:
    assert callable(parse)
    with pytest.raises(UsageError) as excinfo:
        parse(text)
    assert str(excinfo.value) == message


def test_the_typed_values_reach_the_writer(tmp_path: Path) -> None:
    sinks = make_sinks(
        tmp_path / "out", SCHEMA, ("mcap",), WriterConfig(), "png", mcap_compression="lz4", first_index=4
    )
    try:
        (sink,) = sinks
        assert isinstance(sink, McapSink)
        assert (sink.config.image_format, sink.config.compression, sink.first_index) == ("png", "lz4", 4)
        assert sink.root == tmp_path / "out" / "mcap"
    finally:
        for s in sinks:
            s.close()


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        ("formats", ("lerobot", "csv"), "--format: unknown format(s) csv (valid: lerobot, mcap)"),
        ("codec", "vp9", "--vcodec: 'vp9' is not one of av1, h264, hevc, auto"),
        ("image_format", "gif", "--image-format: 'gif' is not one of jpeg, png, raw"),
        ("mcap_compression", "bz2", "--mcap-compression: 'bz2' is not one of zstd, lz4, none"),
    ],
)
def test_options_built_from_untyped_python_are_checked_once_when_built(field: str, value: object, message: str) -> None:
    """The Python API may be called from untyped code: RecordOptions refuses a bad value when it is built, with
    the CLI's own line, so nothing below it needs to check again."""
    with pytest.raises(UsageError) as excinfo:
        RecordOptions(**{field: value})  # type: ignore[arg-type]
    assert str(excinfo.value) == message
