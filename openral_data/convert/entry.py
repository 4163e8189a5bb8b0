"""The one way into a conversion, for the command line (`convert`, `info`, `--print-mapping`), pipelines and the
Python API (`openral_data.convert(...)`): SRC's kind found by the source registry (`convert.kinds`), then that
kind's conversion: a LeRobot dataset -> ROS 2 MCAP bags; bags, HDF5, Zarr or RLDS -> a LeRobot v3 dataset.

`plan` checks everything that can be checked before anything is written (SRC, DST, the options that apply to
SRC's kind, the mapping) and returns the `Plan` whose `run` converts; `convert` does both.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

from openral_data.convert.kinds import BAGS, DATASET, detect
from openral_data.convert.kinds.base import (
    Description,
    Parallel,
    Plan,
    ProgressFn,
    Request,
    StartingMapping,
    no_starting_mapping,
)
from openral_data.errors import NotFound

if TYPE_CHECKING:
    from openral_data.convert.summary import ConvertSummary
    from openral_data.convert.to_mcap import ExportSummary
    from openral_data.formats.lerobot_v3.encoder import VideoSettings
    from openral_data.schemas.mapping import Mapping

MappingArg = Path | str | dict[str, Any] | None  # a mapping file, or its content; see `_mapping`


def plan(source: Path | str, dst: Path | str, request: Request | None = None) -> Plan:
    """`source` (a path, or a Hub repo id of a dataset) and `dst` (a new or empty folder) checked, SRC's kind
    found, and its conversion planned as `request` asks (one line for an option its kind does not take)."""
    from openral_data.formats.repo_id import resolve_dataset
    from openral_data.formats.staging import check_new_output

    src = resolve_dataset(Path(source))
    if not src.exists():
        raise NotFound(f"{src}: no such file or directory")
    out = Path(dst)
    check_new_output(out, "DST")
    found = detect(src)
    kind, handle = (found.kind, found.handle) if found is not None else (BAGS, src)
    return kind.plan(handle, out, request or Request())


def convert(
    source: Path | str,
    dst: Path | str,
    mapping: MappingArg | Mapping = None,
    *,
    video: VideoSettings | None = None,
    parallel: Parallel | None = None,
    fps: int | None = None,
    episodes: str | None = None,
    image_format: str = "jpeg",
    mcap_compression: str = "zstd",
    progress: ProgressFn | None = None,
) -> ConvertSummary | ExportSummary:
    """Convert `source` into the new folder `dst`: bags (ROS 1, rosbag2, MCAP), HDF5 (robomimic, LIBERO,
    MimicGen, ALOHA), a Zarr replay buffer or an RLDS folder -> a LeRobot v3 dataset (`mapping`: a mapping file or
    its content, else the source's starting mapping; `fps`: the rate of an array source that declares none;
    `parallel`: `--workers`); a LeRobot dataset -> ROS 2 MCAP bags (`episodes`, `image_format`,
    `mcap_compression`). `progress(done, total)` is called as it goes."""
    request = Request(_mapping(mapping), video, parallel, fps, episodes, image_format, mcap_compression)
    return plan(source, dst, request).run(progress)


def _mapping(mapping: MappingArg | Mapping) -> Path | Mapping | None:
    from openral_data.schemas.base import validate
    from openral_data.schemas.mapping import Mapping

    if mapping is None or isinstance(mapping, (Path, Mapping)):
        return mapping
    if isinstance(mapping, str):
        return Path(mapping)
    return validate(Mapping, mapping, "mapping")


def describe(path: Path) -> Description:
    """What `info` says of `path`: its kind's description; a LeRobot dataset's when no kind takes it."""
    found = detect(path)
    return found.kind.describe(found.handle) if found is not None else DATASET.describe(path)


def starting_mapping(path: Path, fps: int | None = None) -> StartingMapping:
    """`convert SRC --print-mapping`: the mapping a conversion of `path` without one starts from."""
    if not path.exists():
        raise NotFound(f"{path}: no such file or directory")
    found = detect(path)
    if found is None:
        raise no_starting_mapping(path)
    return found.kind.starting_mapping(found.handle, fps)
