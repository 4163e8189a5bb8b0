"""`record --format`: which sinks one recording feeds, and where each writes inside `--out`.

Layout of one `--out` (the same whether one format or both are chosen, so scripts need not branch):

* ``lerobot`` -> ``OUT/`` is the LeRobot v3 dataset root (``meta/``, ``data/``, ``videos/``), as before;
* ``mcap``    -> ``OUT/mcap/episode_NNNNNN/`` one rosbag2 bag (``metadata.yaml`` + ``.mcap``) per episode.

lerobot's loader only reads ``meta/``, ``data/`` and ``videos/``, so ``mcap/`` beside them is invisible to it.
"""

from __future__ import annotations

from pathlib import Path
from typing import cast

from openral_data.errors import UsageError
from openral_data.formats.lerobot_v3 import LeRobotV3Writer, WriterConfig
from openral_data.formats.mcap import (
    IMAGE_FORMATS,
    MCAP_SUBDIR,
    ImageFormat,
    McapCompression,
    McapConfig,
    McapSink,
    check_compression,
)
from openral_data.types import DatasetSchema, Sink

FORMATS = ("lerobot", "mcap")


def parse_formats(text: str) -> tuple[str, ...]:
    """`lerobot,mcap` -> ("lerobot", "mcap"); unknown or repeated names are errors."""
    names = tuple(part.strip() for part in text.split(",") if part.strip())
    check_formats(names)
    return names


def check_formats(formats: tuple[str, ...], image_format: str = "jpeg", mcap_compression: str = "zstd") -> None:
    if not formats:
        raise UsageError(f"--format: choose at least one of {', '.join(FORMATS)}")
    unknown = [f for f in formats if f not in FORMATS]
    if unknown:
        raise UsageError(f"--format: unknown format(s) {', '.join(unknown)} (valid: {', '.join(FORMATS)})")
    if len(set(formats)) != len(formats):
        raise UsageError(f"--format: a format is listed twice in {','.join(formats)}")
    if image_format not in IMAGE_FORMATS:
        raise UsageError(f"--image-format: {image_format!r} is not one of {', '.join(IMAGE_FORMATS)}")
    check_compression(mcap_compression)


def make_sinks(
    out: Path,
    schema: DatasetSchema,
    formats: tuple[str, ...],
    writer: WriterConfig,
    image_format: str = "jpeg",
    *,
    resume: bool = False,
    mcap_compression: str = "zstd",
) -> list[Sink]:
    """The sinks in commit order: MCAP before LeRobot, so a kill between the two commits of one episode
    leaves an extra bag (one folder `record --resume` sets aside), never an extra LeRobot episode."""
    check_formats(formats, image_format, mcap_compression)
    sinks: list[Sink] = []
    try:
        if "lerobot" in formats:  # created first: it refuses a non-empty OUT before anything lands there
            sinks.append(LeRobotV3Writer(out, schema, writer, resume=resume))
        if "mcap" in formats:
            config = McapConfig(
                image_format=cast(ImageFormat, image_format), compression=cast(McapCompression, mcap_compression)
            )
            sinks.insert(0, McapSink(out / MCAP_SUBDIR, schema, config, resume=resume))
    except BaseException:
        for sink in sinks:
            sink.close()
        raise
    return sinks
