"""`openral-data convert` for array sources (HDF5: robomimic, LIBERO, MimicGen / Isaac Lab, ALOHA): the mapping
(`--mapping`, else the layout's starting mapping), the conversion behind a progress bar, the summary; and
`convert SRC --print-mapping`, the starting mapping with its guesses marked."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from openral_data.cli.convert_common import Parallel, interruptible
from openral_data.cli.jsonout import print_json
from openral_data.cli.terminal import print_line, print_rows, progress_bar
from openral_data.errors import DatasetError, UsageError
from openral_data.formats.lerobot_v3.encoder import VideoSettings

if TYPE_CHECKING:
    from openral_data.convert import ConvertSummary
    from openral_data.formats.episodic import ArrayEpisode, ArraySource
    from openral_data.schemas.mapping import Mapping


def _with_first[T](source: ArraySource, fn: Callable[[ArrayEpisode], T]) -> T:
    """`fn` of the source's first episode (the source closed again after)."""
    episodes = source.episodes()
    try:
        first = next(iter(episodes), None)
        if first is None:
            raise DatasetError(f"{source.path}: no episodes ({source.layout} layout)", code="dataset.source.empty")
        return fn(first)
    finally:
        close = getattr(episodes, "close", None)
        if close is not None:
            close()
        source.close()


def print_starting_mapping(src: Path, fps: int | None, json: bool) -> None:
    """The starting mapping of the array source `src` (an existing path that is no bag), its guesses marked."""
    from openral_data.convert.array_mapping import Guess, mapping_yaml, starting_mapping, with_fps_guess
    from openral_data.convert.array_sources import detect_array_source

    source = detect_array_source(src)
    if source is None:
        raise UsageError(
            f"{src}: --print-mapping applies to bags (.bag, .mcap, rosbag2 folder, folder of bags) and array sources "
            "(HDF5, Zarr replay buffer, RLDS); this is neither"
        )

    def build(first: ArrayEpisode) -> tuple[dict[str, Any], list[Guess]]:
        return starting_mapping(source, first, fps)

    data, guesses = _with_first(source, build)
    with_fps_guess(data, guesses, source.layout)
    if json:
        print_json(
            "convert",
            {
                "source": str(src),
                "layout": source.layout,
                "mapping": {k: v for k, v in data.items() if v not in (None, {})},
                "guesses": {g.key: g.why for g in guesses},
            },
        )
        return
    print_line(mapping_yaml(data, guesses, source.layout).rstrip("\n"))


def array_mapping(source: ArraySource, mapping_path: Path | None, fps: int | None) -> Mapping:
    """The mapping a conversion of `source` uses, its vector parts named (widths from the first episode)."""
    from openral_data.convert.array_mapping import mapping_of, starting_mapping
    from openral_data.convert.from_arrays import named
    from openral_data.schemas.mapping import load_mapping

    if mapping_path is not None and fps is not None:
        raise UsageError("--fps with --mapping: set fps in the mapping")
    loaded = load_mapping(mapping_path) if mapping_path is not None else None

    def build(first: ArrayEpisode) -> Mapping:
        mapping = loaded or mapping_of(starting_mapping(source, first, fps)[0], str(source.path))
        return named(mapping, first, str(source.path))

    return _with_first(source, build)


def convert_array_source(
    source: ArraySource,
    dst: Path,
    mapping_path: Path | None,
    video: VideoSettings,
    fps: int | None,
    json: bool,
    parallel: Parallel | None,
) -> None:
    from openral_data.convert.from_arrays import convert_arrays
    from openral_data.convert.parallel import convert_arrays_parallel

    mapping = array_mapping(source, mapping_path, fps)
    with progress_bar("converting", "steps") as bar, interruptible(bar, dst):
        task = bar.add_task("convert", total=None)

        def progress(done: int, total: int) -> None:
            bar.update(task, completed=done, total=total)

        if parallel is None:
            result = convert_arrays(source, dst, mapping, video=video, progress=progress)
        else:
            result = convert_arrays_parallel(
                source, dst, mapping, parallel.workers, executor=parallel.executor, address=parallel.address,
                video=video, progress=progress,
            )  # fmt: skip
    if json:
        workers = (parallel.workers, parallel.executor) if parallel is not None else (1, None)
        print_json("convert", result.to_json(mapping, *workers))
        return
    print_rows("converted", _rows(source, dst, mapping, result, parallel))


def _rows(
    source: ArraySource, dst: Path, mapping: Mapping, result: ConvertSummary, parallel: Parallel | None
) -> list[tuple[str, str]]:
    rows = [
        ("source", f"{source.path} ({source.layout}, {result.bags} file(s))"),
        *([("workers", f"{parallel.workers} ({parallel.executor})")] if parallel is not None else []),
        ("output", str(dst)),
        ("episodes", str(len(result.episodes))),
        ("frames", f"{result.frames} at {mapping.fps} fps (one frame a step)"),
        ("frames/s", f"{result.fps:.1f}"),
    ]
    for key, rep in result.topics.items():
        rows.append((f"mapped {key}", f"{rep.msgtype}: {rep.messages} steps"))
    reward = f"reward from {mapping.reward.topic}" if mapping.reward is not None else "no reward"
    success = f"success from {mapping.success.topic}" if mapping.success is not None else "success unknown"
    rows.append(("outcomes", f"{reward}; {success}; done on each episode's last frame"))
    return rows
