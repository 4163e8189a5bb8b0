"""`openral-data export DATASET --to rlds|robomimic|mcap OUT`: shows progress, prints the summary."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from openral_data.cli.convert_common import interruptible
from openral_data.cli.jsonout import JsonFlag, print_json
from openral_data.cli.takes import takes
from openral_data.cli.terminal import print_rows, progress_bar


@takes("dataset", pixels=True, v2="in place", writes="new")
def export(
    dataset: Annotated[Path, typer.Argument(help="a LeRobot v3.0 dataset (v2.x read in place), or a repo id")],
    out: Annotated[
        Path, typer.Argument(help="the RLDS folder or MCAP folder (must not exist or be empty), or the .hdf5 file")
    ],
    to: Annotated[str, typer.Option("--to", help="rlds, robomimic or mcap")],
    episodes: Annotated[str | None, typer.Option(help="episodes to export, e.g. 0,3,5-7 (default: all)")] = None,
    workers: Annotated[int, typer.Option(help="write in N processes (rlds: shards, robomimic: parts)")] = 1,
    image_format: Annotated[
        str | None, typer.Option(help="pictures: jpeg (default) or png (rlds); jpeg, png or raw (mcap)")
    ] = None,
    mcap_compression: Annotated[str, typer.Option(help="MCAP chunk compression: zstd, lz4 or none")] = "zstd",
    json: JsonFlag = False,
) -> None:
    """Write DATASET as RLDS (TFDS build folder), robomimic HDF5 or ROS 2 MCAP bags: episodes, language, episode
    metadata and splits carried, pictures decoded."""
    from openral_data.convert.exporting import export as run
    from openral_data.convert.exporting import export_rows
    from openral_data.runtime.parallel.choice import check_workers

    check_workers(workers)
    with progress_bar(f"exporting to {to}", "frames") as bar, interruptible(bar, out):
        task = bar.add_task("exporting", total=None)
        summary = run(
            dataset,
            out,
            to,
            episodes=episodes,
            workers=workers,
            image_format=image_format,
            mcap_compression=mcap_compression,
            progress=lambda d, t: bar.update(task, completed=d, total=t or None),
        )
    if json:
        print_json("export", summary.to_json())
        return
    print_rows("exported", export_rows(summary))
