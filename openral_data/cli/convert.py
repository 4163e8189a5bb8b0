"""`openral-data convert`: picks the direction from SRC, shows progress, prints the summary."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from openral_data.cli.convert_common import interruptible
from openral_data.cli.encoder_flags import (
    VCODEC_HELP,
    CrfFlag,
    GopFlag,
    PixFmtFlag,
    PresetFlag,
    ThreadsFlag,
    video_settings,
)
from openral_data.cli.jsonout import JsonFlag, print_json
from openral_data.cli.takes import takes
from openral_data.cli.terminal import print_line, print_summary, progress_bar
from openral_data.errors import UsageError
from openral_data.formats.codec import Codec

if TYPE_CHECKING:
    from openral_data.convert.kinds.base import Parallel
    from openral_data.formats.lerobot_v3.encoder import VideoSettings


@takes("src", pixels=True, v2="in place", writes="new")
def convert(
    src: Annotated[
        Path,
        typer.Argument(
            help="a bag (.bag, .mcap, rosbag2 folder, folder of bags), an HDF5 file or folder (robomimic, LIBERO, "
            "MimicGen / Isaac Lab, ALOHA), a zarr replay buffer, an RLDS build folder or a LeRobot v3 dataset"
        ),
    ],
    dst: Annotated[
        Path | None, typer.Argument(help="output folder (must not exist or be empty); none with --print-mapping")
    ] = None,
    mapping: Annotated[Path | None, typer.Option(help="mapping YAML: topics or array keys -> features")] = None,
    codec: Annotated[Codec, typer.Option("--vcodec", "--codec", help=f"{VCODEC_HELP} (-> LeRobot)")] = "av1",
    crf: CrfFlag = None,
    gop: GopFlag = None,
    preset: PresetFlag = None,
    pix_fmt: PixFmtFlag = None,
    encoder_threads: ThreadsFlag = None,
    episodes: Annotated[str | None, typer.Option(help="episodes to export, e.g. 0,3,5-7 (LeRobot -> MCAP)")] = None,
    image_format: Annotated[
        str, typer.Option(help="MCAP camera messages: jpeg, png or raw (LeRobot -> MCAP)")
    ] = "jpeg",
    mcap_compression: Annotated[
        str, typer.Option(help="MCAP chunk compression: zstd, lz4 or none (LeRobot -> MCAP)")
    ] = "zstd",
    workers: Annotated[
        int, typer.Option(help="convert bags, HDF5 files or RLDS shards in N processes, merged in order (-> LeRobot)")
    ] = 1,
    executor: Annotated[str, typer.Option(help="local (processes on this machine) or ray (with --workers)")] = "local",
    address: Annotated[str | None, typer.Option(help="Ray cluster address (--executor ray)")] = None,
    fps: Annotated[
        int | None, typer.Option(help="frame rate of an array source that declares none (HDF5/Zarr/RLDS)")
    ] = None,
    print_mapping: Annotated[
        bool, typer.Option("--print-mapping", help="print SRC's starting mapping, guesses marked")
    ] = False,
    json: JsonFlag = False,
) -> None:
    """Convert bags/MCAP, HDF5, Zarr or RLDS to a LeRobot v3 dataset, or a LeRobot v3 dataset to ROS 2 MCAP bags."""
    from openral_data.convert.kinds.base import Parallel
    from openral_data.runtime.parallel.choice import is_parallel
    from openral_data.runtime.parallel.executors import check_executor

    if print_mapping:
        _print_mapping(src, dst, mapping, fps, json)
        return
    if dst is None:
        raise UsageError("DST: missing (the output folder; or --print-mapping to print SRC's starting mapping)")
    if workers < 1:
        raise UsageError(f"--workers must be >= 1, got {workers}")
    check_executor(executor, address)
    parallel = Parallel(workers, executor, address) if is_parallel(workers, executor) else None
    video = video_settings(codec, crf, gop, preset, pix_fmt, encoder_threads)  # a bad combination: before anything
    _convert(src, dst, mapping, video, episodes, image_format, mcap_compression, json, parallel, fps)


def _print_mapping(src: Path, dst: Path | None, mapping: Path | None, fps: int | None, json: bool) -> None:
    """`convert SRC --print-mapping`: SRC's starting mapping as commented YAML (or JSON) on stdout; a bag's
    guessed from its topics, an array source's from its layout (its source kind's)."""
    from openral_data.convert.entry import starting_mapping

    if dst is not None or mapping is not None:
        raise UsageError("--print-mapping: takes SRC only (no DST, no --mapping); it writes nothing")
    start = starting_mapping(src, fps)
    if json:
        print_json("convert", start.to_json())
        return
    print_line(start.text.rstrip("\n"))


def _convert(
    src: Path,
    dst: Path,
    mapping: Path | None,
    video: VideoSettings,
    episodes: str | None,
    image_format: str,
    mcap_compression: str,
    json: bool,
    parallel: Parallel | None = None,
    fps: int | None = None,
) -> None:
    """SRC's kind (the source registry's) plans the conversion, which runs behind a progress bar; its summary
    printed."""
    from openral_data.convert.entry import plan
    from openral_data.convert.kinds.base import Request

    request = Request(mapping, video, parallel, fps, episodes, image_format, mcap_compression)
    planned = plan(src, dst, request)
    with progress_bar(planned.what, planned.unit) as bar, interruptible(bar, dst):
        task = bar.add_task(planned.what, total=None)
        summary = planned.run(lambda d, t: bar.update(task, completed=d, total=t))
    if json:
        print_json("convert", planned.to_json(summary))
        return
    print_summary(planned.done, planned.rows(summary))
