"""`openral-data convert`: picks the direction from SRC, shows progress, prints the summary."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from openral_data.cli.convert_common import Parallel, interruptible
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
from openral_data.cli.terminal import print_line, print_rows, progress_bar
from openral_data.errors import NotFound, UsageError
from openral_data.formats.codec import Codec
from openral_data.formats.repo_id import resolve_dataset

if TYPE_CHECKING:
    from openral_data.convert import ConvertSummary
    from openral_data.formats.lerobot_v3.encoder import VideoSettings
    from openral_data.schemas.mapping import Mapping


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
    from openral_data.runtime.parallel.executors import check_executor

    if print_mapping:
        _print_mapping(src, dst, mapping, fps, json)
        return
    if dst is None:
        raise UsageError("DST: missing (the output folder; or --print-mapping to print SRC's starting mapping)")
    if workers < 1:
        raise UsageError(f"--workers must be >= 1, got {workers}")
    check_executor(executor, address)
    parallel = Parallel(workers, executor, address) if workers != 1 or executor != "local" else None
    video = video_settings(codec, crf, gop, preset, pix_fmt, encoder_threads)  # a bad combination: before anything
    _convert(src, dst, mapping, video, episodes, image_format, mcap_compression, json, parallel, fps)


def _print_mapping(src: Path, dst: Path | None, mapping: Path | None, fps: int | None, json: bool) -> None:
    """`convert SRC --print-mapping`: SRC's guessed starting mapping as commented YAML (or JSON) on stdout;
    a bag's from its topics, an array source's from its layout."""
    from openral_data.cli.convert_arrays import print_starting_mapping
    from openral_data.convert.discover import is_bag_source
    from openral_data.convert.guess_mapping import guess_mapping, mapping_yaml

    if dst is not None or mapping is not None:
        raise UsageError("--print-mapping: takes SRC only (no DST, no --mapping); it writes nothing")
    if not src.exists():
        raise NotFound(f"{src}: no such file or directory")
    if not is_bag_source(src):
        print_starting_mapping(src, fps, json)
        return
    if fps is not None:
        raise UsageError("--fps applies to array sources; a bag's starting mapping guesses its rate from the topics")
    guess = guess_mapping(src)
    if json:
        print_json("convert", {"source": str(src), "layout": "bag", "mapping": guess.mapping, "guesses": guess.notes})
        return
    print_line(mapping_yaml(src, guess).rstrip("\n"))


def _convert(
    src: Path,
    dst: Path,
    mapping_path: Path | None,
    video: VideoSettings,
    episodes: str | None,
    image_format: str,
    mcap_compression: str,
    json: bool,
    parallel: Parallel | None = None,
    fps: int | None = None,
) -> None:
    """Resolve SRC and DST, then run the direction SRC asks for: a LeRobot dataset is exported to MCAP bags,
    anything else is a bag (or a folder of them) converted to a LeRobot dataset."""
    from openral_data.convert.array_sources import detect_array_source
    from openral_data.convert.to_mcap import is_lerobot_dataset

    src = _resolve(src, dst)
    if is_lerobot_dataset(src):
        _export(src, dst, mapping_path, episodes, image_format, mcap_compression, json, parallel)
    elif (source := detect_array_source(src)) is not None:
        from openral_data.cli.convert_arrays import convert_array_source

        if episodes is not None:
            raise UsageError(
                f"--episodes selects episodes of a LeRobot dataset; SRC is an array source ({source.layout})"
            )
        convert_array_source(source, dst, mapping_path, video, fps, json, parallel)
    else:
        if fps is not None:
            raise UsageError("--fps applies to array sources (HDF5, Zarr, RLDS); a bag's rate is its mapping's fps")
        _convert_bags(src, dst, mapping_path, video, episodes, json, parallel)


def _resolve(src: Path, dst: Path) -> Path:
    """SRC as a local path (a Hub repo id resolved) that exists; DST a new or empty folder."""
    from openral_data.formats.staging import check_new_output

    src = resolve_dataset(src)
    if not src.exists():
        raise NotFound(f"{src}: no such file or directory")
    check_new_output(dst, "DST")
    return src


def _export(
    src: Path,
    dst: Path,
    mapping_path: Path | None,
    episodes: str | None,
    image_format: str,
    mcap_compression: str,
    json: bool,
    parallel: Parallel | None,
) -> None:
    """LeRobot dataset -> MCAP: check the options that apply, run the export, report it."""
    from openral_data.convert.to_mcap import export_mcap
    from openral_data.formats.mcap import McapConfig, parse_compression, parse_image_format

    if parallel is not None:
        raise UsageError(f"{src}: is a LeRobot dataset (exported to MCAP); --workers/--executor apply to bags only")
    if mapping_path is not None:
        raise UsageError(f"{src}: is a LeRobot dataset (exported to MCAP); --mapping applies to bags only")
    image = parse_image_format(image_format)  # `--image-format` and `--mcap-compression` apply to MCAP only
    mcap = McapConfig(image_format=image, compression=parse_compression(mcap_compression))
    with progress_bar("exporting", "frames") as bar, interruptible(bar, dst):
        task = bar.add_task("export", total=None)
        summary = export_mcap(
            src, dst, episodes=episodes, config=mcap, progress=lambda d, t: bar.update(task, completed=d, total=t)
        )
    if json:
        print_json("convert", summary.to_json())
        return
    print_rows(
        "exported",
        [
            ("source", str(src)),
            ("output", f"{dst} (one rosbag2/MCAP bag per episode)"),
            ("episodes", ", ".join(str(e.index) for e in summary.episodes)),
            ("frames", str(summary.frames)),
            ("frames/s", f"{summary.fps:.1f}"),
            ("not exported", ", ".join(summary.skipped_features) or "-"),
        ],
    )


def _convert_bags(
    src: Path,
    dst: Path,
    mapping_path: Path | None,
    video: VideoSettings,
    episodes: str | None,
    json: bool,
    parallel: Parallel | None,
) -> None:
    """Bags -> LeRobot: check the options that apply, open the bags and their mapping, run, report."""
    from openral_data.convert.own_bags import own_bags_mapping
    from openral_data.convert.sources import find_bags
    from openral_data.schemas.mapping import load_mapping

    if episodes is not None:
        raise UsageError("--episodes selects episodes of a LeRobot dataset; SRC is a bag")
    bags = find_bags(src)
    mapping = load_mapping(mapping_path) if mapping_path is not None else own_bags_mapping(bags)
    result = _run_bags(src, dst, mapping, video, parallel)
    if json:
        if parallel is None:
            print_json("convert", result.to_json(mapping))
        else:
            print_json("convert", result.to_json(mapping, parallel.workers, parallel.executor))
        return
    print_rows("converted", _bag_rows(src, dst, mapping, result, parallel))


def _run_bags(
    src: Path, dst: Path, mapping: Mapping, video: VideoSettings, parallel: Parallel | None
) -> ConvertSummary:
    """Convert in this process, or across `parallel`'s workers, behind a progress bar."""
    from openral_data.convert.to_lerobot import convert_bags

    with progress_bar("converting", "messages") as bar, interruptible(bar, dst):
        task = bar.add_task("convert", total=None)
        if parallel is None:
            return convert_bags(
                src,
                dst,
                mapping,
                video=video,
                progress=lambda d, t: bar.update(task, completed=d, total=t),
            )
        from openral_data.convert.parallel import convert_parallel

        return convert_parallel(
            src,
            dst,
            mapping,
            parallel.workers,
            executor=parallel.executor,
            address=parallel.address,
            video=video,
            progress=lambda d, t: bar.update(task, completed=d, total=t),
        )


def _bag_rows(
    src: Path, dst: Path, mapping: Mapping, result: ConvertSummary, parallel: Parallel | None
) -> list[tuple[str, str]]:
    """The summary table of a bags -> LeRobot conversion."""
    rows = [
        ("source", f"{src} ({result.bags} bag(s))"),
        *([("workers", f"{parallel.workers} ({parallel.executor})")] if parallel is not None else []),
        ("output", str(dst)),
        ("episodes", str(len(result.episodes))),
        (
            "frames",
            f"{result.frames} at {mapping.fps} fps ({mapping.align.method}, max staleness "
            f"{mapping.align.max_staleness:g} s)",
        ),
        ("frames/s", f"{result.fps:.1f}"),
    ]
    for topic, rep in result.topics.items():
        rows.append(
            (
                f"mapped {topic}",
                f"{rep.msgtype}: {rep.messages} msgs, {rep.used} used, {rep.unused} unused (superseded or outside "
                f"every frame), {rep.unfillable_frames} frames unfillable",
            )
        )
    rows.append(
        (
            "unfillable frames",
            f"{result.unfillable_frames} skipped, never zero-filled ({result.splits} episode split(s) at gaps, "
            f"{result.empty_segments} source episode(s) without a single filled frame)",
        )
    )
    if mapping.align.clock == "header":
        rows.append(
            (
                "late messages",
                f"{result.late_messages} not used (stamp more than align.reorder behind the newest stamp read)",
            )
        )
    rows.append(("outcomes", _outcomes(mapping)))
    for topic, count in sorted(result.skipped_topics.items()):
        rows.append((f"skipped {topic}", f"{count} msgs (not in the mapping)"))
    for topic, count in sorted(result.trailing_bytes.items()):
        rows.append(
            (
                f"trailing bytes {topic}",
                f"{count} msgs with bytes after their last field (ignored, as ROS 1's own reader does)",
            )
        )
    return rows


def _outcomes(mapping: Mapping) -> str:
    reward = (
        f"reward from {mapping.reward.topic}" if mapping.reward is not None else "no reward (no next.reward column)"
    )
    if mapping.success is None:
        success = "success unknown (no next.success column, episode success NULL)"
    else:
        parts = [p for p in (mapping.success.topic, "end markers" if mapping.success.marker else None) if p]
        success = "success from " + " + ".join(parts)
    return f"{reward}; {success}; done on each episode's last frame"
