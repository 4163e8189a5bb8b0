"""`openral-data export DATASET --to FORMAT OUT`: a LeRobot dataset (v3.0, or v2.x read in place) written in
another ecosystem's format, its episodes (all or `--episodes`), language, episode metadata and splits carried:

- ``rlds``: an RLDS / TFDS build folder (`to_rlds`) for OpenVLA, Octo and the Open X-Embodiment tooling;
- ``robomimic``: one robomimic HDF5 file (`to_robomimic`) for robomimic, MimicGen and Isaac Lab Mimic;
- ``mcap``: one ROS 2 MCAP bag an episode (`to_mcap`, what `convert DATASET DST` writes too).

`export(...)` is the one entry (the CLI's and the Python API's); `export_rows` its summary table.
"""

from __future__ import annotations

from pathlib import Path

from openral_data.convert.to_mcap import ExportSummary, ProgressFn
from openral_data.errors import UsageError

FORMATS = ("rlds", "robomimic", "mcap")
_WHAT = {
    "rlds": "an RLDS / TFDS build folder: one split a tfrecord shard set",
    "robomimic": "one robomimic HDF5 file: data/demo_N, mask/<split>",
    "mcap": "one rosbag2/MCAP bag per episode",
}


def export(
    src: Path,
    out: Path,
    to: str,
    *,
    episodes: str | None = None,
    workers: int = 1,
    image_format: str | None = None,
    mcap_compression: str = "zstd",
    progress: ProgressFn | None = None,
) -> ExportSummary:
    """Write the dataset at `src` as `to` (rlds, robomimic or mcap) into the new `out`. `image_format`: RLDS's
    and MCAP's picture encoding (jpeg by default; png; MCAP also raw); `workers`: RLDS and robomimic only."""
    if to not in FORMATS:
        raise UsageError(f"--to: {to!r} is not one of {', '.join(FORMATS)}")
    if to == "rlds":
        from openral_data.convert.to_rlds import export_rlds

        fmt = image_format or "jpeg"
        return export_rlds(src, out, episodes=episodes, workers=workers, image_format=fmt, progress=progress)
    if image_format is not None and to == "robomimic":
        raise UsageError("--image-format: robomimic stores decoded pixels (uint8 HxWxC); it takes no image format")
    if to == "robomimic":
        from openral_data.convert.to_robomimic import export_robomimic

        return export_robomimic(src, out, episodes=episodes, workers=workers, progress=progress)
    if workers != 1:
        raise UsageError("--workers: MCAP is exported in one process (--to rlds or robomimic take --workers)")
    from openral_data.convert.to_mcap import export_mcap
    from openral_data.formats.mcap import McapConfig, parse_compression, parse_image_format

    config = McapConfig(
        image_format=parse_image_format(image_format or "jpeg"), compression=parse_compression(mcap_compression)
    )
    return export_mcap(src, out, episodes=episodes, config=config, progress=progress)


def export_rows(summary: ExportSummary) -> list[tuple[str, str]]:
    """The summary table `export` prints."""
    from openral_data.convert.kinds.report import export_rows as mcap_rows

    rows = mcap_rows(summary.src, summary.dst, summary)
    return [(k, f"{summary.dst} ({_WHAT[summary.format]})" if k == "output" else v) for k, v in rows]
