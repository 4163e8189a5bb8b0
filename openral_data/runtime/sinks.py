"""`record --format`: which sinks one recording feeds, and where each writes inside `--out`.

Layout of one `--out` (the same whether one format or both are chosen, so scripts need not branch):

* ``lerobot`` -> ``OUT/`` is the LeRobot v3 dataset root (``meta/``, ``data/``, ``videos/``), as before;
* ``mcap``    -> ``OUT/mcap/episode_NNNNNN/`` one rosbag2 bag (``metadata.yaml`` + ``.mcap``) per episode.

lerobot's loader only reads ``meta/``, ``data/`` and ``videos/``, so ``mcap/`` beside them is invisible to it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal, cast

from openral_data.errors import UsageError
from openral_data.formats.codec import parse_codec
from openral_data.formats.lerobot_v3 import LeRobotV3Writer, WriterConfig
from openral_data.formats.mcap import (
    ImageFormat,
    McapCompression,
    McapConfig,
    McapSink,
    bags_dir,
    parse_compression,
    parse_image_format,
)
from openral_data.types import DatasetSchema, Sink

OutputFormat = Literal["lerobot", "mcap"]
FORMATS: tuple[OutputFormat, ...] = ("lerobot", "mcap")


def parse_formats(text: str) -> tuple[OutputFormat, ...]:
    """`lerobot,mcap` -> ("lerobot", "mcap"); unknown or repeated names are errors. The one check of `--format`:
    below the edge a tuple of `OutputFormat` is trusted."""
    names = tuple(part.strip() for part in text.split(",") if part.strip())
    if not names:
        raise UsageError(f"--format: choose at least one of {', '.join(FORMATS)}")
    unknown = [f for f in names if f not in FORMATS]
    if unknown:
        raise UsageError(f"--format: unknown format(s) {', '.join(unknown)} (valid: {', '.join(FORMATS)})")
    if len(set(names)) != len(names):
        raise UsageError(f"--format: a format is listed twice in {','.join(names)}")
    return cast(tuple[OutputFormat, ...], names)


def check_outputs(
    formats: tuple[str, ...], codec: str, image_format: str = "jpeg", mcap_compression: str = "zstd"
) -> None:
    """An options object's output settings, checked once when it is built: the CLI hands typed values, but the
    Python API may be called from untyped code; a bad value is the same one line the CLI gives."""
    parse_formats(",".join(formats))
    parse_codec(codec)
    parse_image_format(image_format)
    parse_compression(mcap_compression)


def make_sinks(
    out: Path,
    schema: DatasetSchema,
    formats: tuple[OutputFormat, ...],
    writer: WriterConfig,
    image_format: ImageFormat = "jpeg",
    *,
    resume: bool = False,
    mcap_compression: McapCompression = "zstd",
    first_index: int = 0,
) -> list[Sink]:
    """The sinks in commit order: MCAP before LeRobot, so a kill between the two commits of one episode
    leaves an extra bag (one folder `record --resume` sets aside), never an extra LeRobot episode.
    `first_index`: the number of the first MCAP bag (a `--workers` share writes under its final numbers)."""
    sinks: list[Sink] = []
    try:
        if "lerobot" in formats:  # created first: it refuses a non-empty OUT before anything lands there
            sinks.append(LeRobotV3Writer(out, schema, writer, resume=resume))
        if "mcap" in formats:
            config = McapConfig(image_format=image_format, compression=mcap_compression)
            sinks.insert(0, McapSink(bags_dir(out), schema, config, resume=resume, first_index=first_index))
    except BaseException:
        for sink in sinks:
            sink.close()
        raise
    return sinks
